"""Fit planning-model parameters to judo's logs with MuJoCo's own system identification
(`mujoco.sysid`).

A log (collect's HDF5, a GUI recording in the same layout, or the ROS 2 bridge's MCAP) holds each
step's plant state and the action served during it. The fit cuts every episode into windows of K
steps, rolls each window out from its logged start state under its logged actions on the planning
model with candidate parameters, and minimises the normalised difference to the logged states
(`mujoco.sysid`'s residual and least-squares optimizer). A log whose plant reported only its
measured sensors is compared on those instead (the rollouts' sensordata against each value at the
step it was taken), each window starting from the logged estimate refined, for each candidate, to
the window's own measurements (`judo.sysid.hooks.refine_starts`). The parameters are named MjModel
fields by element (judo.core.configuration.model_overrides), so the result is a
[model_overrides.TASK] section that `--config` reads. Commands that reach the plant whole steps late
(a bridge under load) are a command delay, fitted by trying each; some windows are held out of the
fit and the fitted model's error is reported on them; a fit that leaves most of the error it could
explain is flagged, with the parameters most likely missing (judo.sysid.quality).

mujoco.sysid (the `sysid` extra, `mujoco[sysid]`) is imported only by `fit`.
"""

import dataclasses
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.model_overrides import model_value
from judo.core.errors import import_extra
from judo.core.task import Task
from judo.sysid import quality
from judo.sysid.data import Episode, compared
from judo.sysid.hooks import least_squares, refined_residuals
from judo.sysid.parameters import (
    DELAY,
    FitParameter,
    delay_fits_model,
    fitted_model,
    parameter_rows,
)
from judo.sysid.windows import Windows, cut_windows, rms

EXTRA = "sysid"
"""The optional extra holding mujoco.sysid's dependencies (`mujoco[sysid]`)."""
MAX_DELAY = 0.1
"""Seconds: the most actuation delay `--fit-delay` considers (the fit reads this much action history
before each window)."""
POSITION_SPAN = 0.5
"""Metres a fitted position (body_ipos.trunk[0], ...) may move from the planning model's value,
either way."""
POSITION_SCALE = 0.01
"""Metres: the size of a fitted position near 0, for the optimizer's scaling and the excited
test."""
EXCITED_REL_INTERVAL = 0.25
"""A fitted parameter whose 95% confidence half-width exceeds this fraction of its value is not
excited by the data: it is reported, not written."""
MAX_COMMAND_DELAY = 3
"""Most whole steps of command delay the fit tries when none is given (--command-delay auto): 0 to
3."""


@dataclass
class FitResult:
    """What a fit found.

    Attributes:
        parameters: the fitted parameters, in --params order.
        planning: (P,) each parameter's value in the planning model before the fit.
        fitted: (P,) each parameter's fitted value.
        interval: (P,) the 95% confidence half-width of each (inf where the data do not determine
            it).
        excited: (P,) whether the data determine each parameter (interval within
            EXCITED_REL_INTERVAL of it).
        condition: cond(J) of the residual's Jacobian at the fit, columns scaled by the parameters'
            values.
        error_before, error_after: the K-step prediction error (`prediction_error`) on the planning
            model (the actions as logged) and on the fitted one (with the command delay), on the
            windows fitted.
        num_windows, window_steps: the windows fitted.
        seconds: the fit's wall time.
        compare: what the fit compared: "states" (the logged plant states) or "sensors" (the
            measured sensors).
        from_estimate: whether each window started from the logged estimate (else from the logged
            state).
        timestep: the planning model's step (s): a window lasts window_steps of it.
        command_delay: whole steps each logged action reached the plant
            late (applied `command_delay` steps after it was served), given or chosen by the lowest
            fitted prediction error among those in `delay_errors`.
        delay_errors: {steps: the fitted model's prediction error on the training windows with that
            command delay}.
        held_out_before, held_out_after: the prediction error on the held-out windows (NaN without
            any), on the planning model and on the fitted one.
        num_held_out: windows held out of the fit (every HOLD_OUT_EVERY-th); num_windows counts
            those fitted.
        noise: the prediction error measurement noise alone would leave (`noise_floor` of the fitted
            residuals).
        likely_missing: [(name, share)]: where the fit explains little, the parameters not fitted
            that would remove the largest share of what is left, to first
            order (`first_order_gains`), largest first.
    """

    parameters: list[FitParameter]
    planning: np.ndarray
    fitted: np.ndarray
    interval: np.ndarray
    excited: np.ndarray
    condition: float
    error_before: float
    error_after: float
    num_windows: int
    window_steps: int
    seconds: float
    compare: str = "states"
    from_estimate: bool = False
    timestep: float = 0.0
    command_delay: int = 0
    delay_errors: dict[int, float] = dataclasses.field(default_factory=dict)
    held_out_before: float = math.nan
    held_out_after: float = math.nan
    num_held_out: int = 0
    noise: float = 0.0
    likely_missing: list[tuple[str, float]] = dataclasses.field(default_factory=list)

    @property
    def removed(self) -> float:
        """The share of the training windows' prediction error the fit removed: 1 - error_after /
        error_before."""
        return 1.0 - self.error_after / self.error_before if self.error_before > 0 else 0.0

    @property
    def explains_log(self) -> bool:
        """Whether the fitted model explains the log (`judo.sysid.quality.explains`): where not, its
        intervals do not hold."""
        return quality.explains(self.error_before, self.error_after, self.noise)

    def overrides(self, model: mujoco.MjModel) -> dict[str, dict[str, Any]]:
        """{field: {element: row}} of the determined model parameters (excited, in a fit that
        explains the log), each whole row as `model` holds it otherwise; the delay is among them (as
        actuator_delay of every actuator) only where `model` keeps the action history that MuJoCo's
        actuator delay needs (`delay_fits_model`)."""
        ok = self.excited & self.explains_log
        chosen = [
            (p, v) for p, v, keep in zip(self.parameters, self.fitted, ok, strict=True) if keep
        ]
        overrides = parameter_rows(model, [(p, v) for p, v in chosen if p.field != DELAY])
        if self.delay is not None and delay_fits_model(model, self.delay):
            names = [model.actuator(i).name for i in range(model.nu)]
            overrides["actuator_delay"] = {name: np.array([self.delay]) for name in names}
        return overrides

    @property
    def delay(self) -> float | None:
        """The fitted actuation delay (s), where --fit-delay fitted one the data determine; else
        None."""
        for parameter, value, ok in zip(
            self.parameters, self.fitted, self.excited & self.explains_log, strict=True
        ):
            if parameter.field == DELAY and ok:
                return float(value)
        return None


def fit(
    task: Task,
    parameters: list[FitParameter],
    episodes: list[Episode],
    window_steps: int,
    max_iters: int = 50,
    on_evaluation: Callable[[int], None] | None = None,
    compare: str = "auto",
    command_delay: int | None = None,
) -> FitResult:
    """Fit `parameters` of `task`'s planning model to `episodes` over windows of `window_steps`
    steps.

    `compare` (judo.sysid.data.COMPARE_CHOICES) says what the model's predictions are compared with:
    the logged plant states, or the task's measured sensors as the plant reported them (the
    sensordata mujoco.sysid rolls out, at the steps they were taken), each window then starting from
    the logged estimate where there is one; auto takes the sensors where every episode holds them.

    `command_delay`: whole steps each logged action reached the plant late; None tries 0, 1, ...
    MAX_COMMAND_DELAY on the same windows, fitting the parameters for each until the fitted error is
    at the noise or rises, and keeps the lowest (0 only, with DELAY_PARAMETER: the actuation delay
    in seconds, within [0, MAX_DELAY], the logged actions read that late, `delayed_controls`). Each
    parameter starts at the planning model's value, bounded to [value / 10, value * 10] ([0, 1]
    where the model holds 0; a position, a field ending in "pos", to value ± POSITION_SPAN). Every
    HOLD_OUT_EVERY-th window is held out. `on_evaluation(n)` is called after the n-th evaluation of
    the residual (a progress bar).
    """
    sysid = import_extra("mujoco.sysid", "python -m judo sysid", EXTRA)
    if not hasattr(sysid, "optimize"):  # mujoco.sysid swallows its own ImportError
        import_extra("scipy", "python -m judo sysid", EXTRA)
        import_extra("colorama", "python -m judo sysid", EXTRA)
    # mujoco.sysid's warnings (a sensor layout it does not use) stay quiet
    absl = logging.getLogger("absl")
    level = absl.level
    absl.setLevel(logging.ERROR)
    try:
        return _fit(
            sysid,
            task,
            parameters,
            episodes,
            window_steps,
            max_iters,
            on_evaluation,
            compare,
            command_delay,
        )
    finally:
        absl.setLevel(level)


def _fit(
    sysid: Any,
    task: Task,
    parameters: list[FitParameter],
    episodes: list[Episode],
    window_steps: int,
    max_iters: int,
    on_evaluation: Callable[[int], None] | None,
    compare: str,
    command_delay: int | None,
) -> FitResult:
    began = time.perf_counter()
    model, timestep = task.model, float(task.model.opt.timestep)
    delay_at = next((i for i, p in enumerate(parameters) if p.field == DELAY), None)
    history = int(np.ceil(MAX_DELAY / timestep)) + 1 if delay_at is not None else 0
    compare = compared(episodes, compare)
    tried = list(range(MAX_COMMAND_DELAY + 1)) if delay_at is None else [0]
    shifts = tried if command_delay is None else [command_delay]
    evaluations = [0]

    def counted() -> None:
        evaluations[0] += 1
        if on_evaluation is not None:
            on_evaluation(evaluations[0])

    # (training, held out), the same windows for every shift
    def cut(shift: int) -> tuple[Windows, Windows | None]:
        windows = cut_windows(
            episodes, window_steps, history, compare, task.measured, timestep, shift, max(shifts)
        )
        return quality.split_windows(windows, quality.HOLD_OUT_EVERY)

    delay_errors: dict[int, float] = {}
    best: tuple[Any, ...] | None = None
    for shift in shifts:
        training, held_out = cut(shift)
        found = _fit_windows(sysid, model, parameters, training, max_iters, counted)
        delay = float(found[0][delay_at]) if delay_at is not None else 0.0
        residuals = refined_residuals(fitted_model(model, parameters, found[0]), training, delay)
        delay_errors[shift] = rms(residuals)
        if best is None or delay_errors[shift] < delay_errors[best[0]]:
            best = (shift, training, held_out, found, delay, residuals)
        else:  # the error rose: a longer delay fits worse still
            break
        # nothing left to explain
        if quality.at_noise(delay_errors[shift], quality.noise_floor(residuals)):
            break
    assert best is not None
    shift, training, held_out, (fitted, interval, excited, condition), delay, residuals = best
    plain, plain_held_out = cut(0)  # the planning model under the actions as logged
    fitted_one = fitted_model(model, parameters, fitted)
    result = FitResult(
        parameters,
        np.array([_entry(model, p) for p in parameters]),
        fitted,
        interval,
        excited,
        condition,
        rms(refined_residuals(model, plain, 0.0)),
        delay_errors[shift],
        len(training.starts),
        window_steps,
        0.0,
        compare,
        training.from_estimate,
        timestep,
        shift,
        delay_errors,
        math.nan if plain_held_out is None else rms(refined_residuals(model, plain_held_out, 0.0)),
        math.nan if held_out is None else rms(refined_residuals(fitted_one, held_out, delay)),
        0 if held_out is None else len(held_out.starts),
        quality.noise_floor(residuals),
    )
    if not result.explains_log:
        known = [p.key for p in parameters if p.field != DELAY]
        result.likely_missing = quality.likely_missing(fitted_one, training, delay, known)
    result.seconds = time.perf_counter() - began
    return result


def _fit_windows(
    sysid: Any,
    model: mujoco.MjModel,
    parameters: list[FitParameter],
    windows: Windows,
    max_iters: int,
    counted: Callable[[], None],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """mujoco.sysid's least-squares fit of `parameters` to `windows`: ((P,) fitted, (P,) 95%
    half-widths, (P,) excited, cond(J) of the Jacobian with its columns scaled by the
    parameters)."""
    timestep = float(model.opt.timestep)
    delay_at = next((i for i, p in enumerate(parameters) if p.field == DELAY), None)
    nominal = np.array([_entry(model, p) for p in parameters])
    scale = np.where(np.abs(nominal) > 0, np.abs(nominal), 1.0)
    positions = np.array([p.field.endswith("pos") for p in parameters], dtype=bool)
    scale[positions] = np.maximum(np.abs(nominal[positions]), POSITION_SCALE)
    bounds = []
    for index, value in enumerate(nominal):
        if index == delay_at:  # from half a step, inside its bounds, on the scale of a step
            low, high, start, scale[index] = 0.0, MAX_DELAY, 0.5 * timestep, timestep
        elif positions[index]:
            low, high, start = value - POSITION_SPAN, value + POSITION_SPAN, value
        else:
            low, high = (
                (value / 10, value * 10)
                if value > 0
                else ((0.0, 1.0) if value == 0 else (value * 10, value / 10))
            )
            start = value
        bounds.append((low, high, start))

    def build_model(candidate: Any) -> mujoco.MjModel:
        return fitted_model(
            model, parameters, np.array([candidate[p.name].value[0] for p in parameters])
        )

    names = [p.name for p in parameters]
    delay_name = DELAY if delay_at is not None else None
    fitted, interval, jacobian = least_squares(
        sysid, model, windows, names, bounds, scale, build_model, delay_name, max_iters, counted
    )
    scaled = jacobian * scale[None, :]
    condition = float(np.linalg.cond(scaled)) if scaled.size else float("inf")
    size = np.maximum(np.abs(fitted), 1e-12)
    size[positions] = np.maximum(size[positions], POSITION_SCALE)
    # a delay near 0 is determined when known to within a quarter of a step
    if delay_at is not None:
        size[delay_at] = max(size[delay_at], timestep)
    excited = np.isfinite(interval) & (interval <= EXCITED_REL_INTERVAL * size)
    return fitted, interval, excited, condition


def _entry(model: mujoco.MjModel, parameter: FitParameter) -> float:
    """The parameter's value in `model`: 0 for the delay, 1 for a whole row's factor, else its
    entry."""
    if parameter.field == DELAY or parameter.whole:
        return float(parameter.whole)
    return float(model_value(model, parameter.field, parameter.element)[parameter.index or 0])
