"""Fit planning-model parameters to judo's logs with MuJoCo's own system identification (`mujoco.sysid`).

A log (collect's HDF5, a GUI recording in the same layout, or the ROS 2 bridge's MCAP) holds each step's plant
state and the action served during it. The fit cuts every episode into windows of K steps, rolls each window
out from its logged start state under its logged actions on the planning model with candidate parameters, and
minimises the normalised difference to the logged states (`mujoco.sysid`'s residual and least-squares
optimizer). A log whose plant reported only its measured sensors is compared on those instead (the rollouts'
sensordata against each value at the step it was taken), each window starting from the logged estimate refined,
for each candidate, to the window's own measurements (`sysid_hooks.refine_starts`). The parameters are named
MjModel fields by element (judo.core.model_overrides), so the result is a [model_overrides.TASK] section that
`--config` reads.

mujoco.sysid (the `sysid` extra, `mujoco[sysid]`) is imported only by `fit`.
"""

import contextlib
import io
import logging
import re
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from judo.collection.sysid_data import (
    Episode,
    compared,
    cut_windows,
    spread,
)
from judo.collection.sysid_hooks import (
    batched_residual,
    delayed_rollout,
    model_sequences,
    observed_residual,
    refined_prediction_error,
    refined_rollout,
)
from judo.core.errors import ConfigError, import_extra
from judo.core.model_overrides import check_model_overrides, model_value, overridden
from judo.core.task import Task

EXTRA = "sysid"
"""The optional extra holding mujoco.sysid's dependencies (`mujoco[sysid]`)."""
MAX_DELAY = 0.1
"""Seconds: the most actuation delay `--fit-delay` considers (the fit reads this much action history before each
window)."""
DELAY = "delay"
"""The field of the FitParameter that stands for the actuation delay (--fit-delay), in seconds, of every actuator."""
POSITION_SPAN = 0.5
"""Metres a fitted position (body_ipos.trunk[0], ...) may move from the planning model's value, either way."""
POSITION_SCALE = 0.01
"""Metres: the size of a fitted position near 0, for the optimizer's scaling and the excited test."""
EXCITED_REL_INTERVAL = 0.25
"""A fitted parameter whose 95% confidence half-width exceeds this fraction of its value is not excited by the
data: it is reported, not written."""


@dataclass(frozen=True)
class FitParameter:
    """One parameter to fit: entry `index` of `element`'s row of the MjModel `field` (None: the leading entry, the
    row's one value or, as MJCF reads friction="0.9" or gear="9.1", its first)."""

    field: str
    element: str
    index: int | None = None

    @property
    def name(self) -> str:
        """How the command line and the report name it: "body_mass.pole" or "geom_friction.cube[0]"; "delay" for
        the actuation delay."""
        if self.field == DELAY:
            return DELAY
        return f"{self.field}.{self.element}" + ("" if self.index is None else f"[{self.index}]")


DELAY_PARAMETER = FitParameter(DELAY, "actuators")
"""The actuation delay (s) of every actuator, fitted with --fit-delay: each logged action takes effect that late."""


def parse_parameters(texts: list[str] | tuple[str, ...], model: mujoco.MjModel) -> list[FitParameter]:
    """`--params` entries ("FIELD.ELEMENT" or "FIELD.ELEMENT[i]") checked against `model`: UnknownNameError for an
    unknown field or element (listing the valid names), ConfigError for another form or an index out of range."""
    parameters = []
    for text in texts:
        match = re.fullmatch(r"([a-z0-9_]+)\.([^\[\]]+)(?:\[(\d+)\])?", text)
        if match is None:
            raise ConfigError(f"--params takes FIELD.ELEMENT or FIELD.ELEMENT[i] (e.g. body_mass.pole), got {text!r}")
        field, element, index = match.group(1), match.group(2), match.group(3)
        check_model_overrides(model, {field: {element: 0.0}})  # the field and element exist
        current = model_value(model, field, element)
        if index is not None and int(index) >= current.size:
            raise ConfigError(
                f"--params {text}: {field}.{element} has {current.size} entries, index 0 to {current.size - 1}"
            )
        parameters.append(FitParameter(field, element, None if index is None else int(index)))
    if not parameters:
        raise ConfigError("--params needs at least one FIELD.ELEMENT to fit, e.g. body_mass.pole")
    return parameters


@dataclass
class FitResult:
    """What a fit found.

    Attributes:
        parameters: the fitted parameters, in --params order.
        planning: (P,) each parameter's value in the planning model before the fit.
        fitted: (P,) each parameter's fitted value.
        interval: (P,) the 95% confidence half-width of each (inf where the data do not determine it).
        excited: (P,) whether the data determine each parameter (interval within EXCITED_REL_INTERVAL of it).
        condition: cond(J) of the residual's Jacobian at the fit, columns scaled by the parameters' values.
        error_before, error_after: the K-step prediction error (`prediction_error`) on the planning model
            and on the fitted one.
        num_windows, window_steps: the windows fitted.
        seconds: the fit's wall time.
        compare: what the fit compared: "states" (the logged plant states) or "sensors" (the measured sensors).
        from_estimate: whether each window started from the logged estimate (else from the logged state).
        timestep: the planning model's step (s): a window lasts window_steps of it.
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

    def overrides(self, model: mujoco.MjModel) -> dict[str, dict[str, Any]]:
        """{field: {element: row}} of the excited model parameters, each whole row as `model` holds it otherwise;
        the delay is among them (as actuator_delay of every actuator) only where `model` keeps the action history
        that MuJoCo's actuator delay needs (`delay_fits_model`)."""
        chosen = [(p, v) for p, v, excited in zip(self.parameters, self.fitted, self.excited, strict=True) if excited]
        overrides = parameter_rows(model, [(p, v) for p, v in chosen if p.field != DELAY])
        if self.delay is not None and delay_fits_model(model, self.delay):
            names = [model.actuator(i).name for i in range(model.nu)]
            overrides["actuator_delay"] = {name: np.array([self.delay]) for name in names}
        return overrides

    @property
    def delay(self) -> float | None:
        """The fitted actuation delay (s), where --fit-delay fitted one the data determine; else None."""
        for parameter, value, excited in zip(self.parameters, self.fitted, self.excited, strict=True):
            if parameter.field == DELAY and excited:
                return float(value)
        return None


def delay_fits_model(model: mujoco.MjModel, delay: float) -> bool:
    """Whether every actuator of `model` keeps enough action history (MJCF's nsample, compiled in) for MuJoCo's
    actuator_delay to hold `delay` seconds: without it MuJoCo ignores actuator_delay."""
    needed = int(np.ceil(delay / float(model.opt.timestep) - 1e-9)) + 1
    return model.nu > 0 and bool(np.all(model.actuator_history[:, 0] >= needed))


def parameter_rows(model: mujoco.MjModel, values: list[tuple[FitParameter, float]]) -> dict[str, dict[str, Any]]:
    """{field: {element: row}}: each parameter's value set in its row of `model` (the rest of the row as it is)."""
    rows: dict[tuple[str, str], np.ndarray] = {}
    for parameter, value in values:
        if parameter.field == DELAY:  # a delay of the actions, not of the model
            continue
        key = (parameter.field, parameter.element)
        rows.setdefault(key, model_value(model, *key).copy())[parameter.index or 0] = value
    overrides: dict[str, dict[str, Any]] = {}
    for (field, element), row in rows.items():
        overrides.setdefault(field, {})[element] = row
    return overrides


def fitted_model(model: mujoco.MjModel, parameters: list[FitParameter], values: np.ndarray) -> mujoco.MjModel:
    """A copy of `model` with each parameter set to its value in `values` (P,)."""
    return overridden(model, parameter_rows(model, list(zip(parameters, values, strict=True))))


def fit(
    task: Task,
    parameters: list[FitParameter],
    episodes: list[Episode],
    window_steps: int,
    max_iters: int = 50,
    on_evaluation: Callable[[int], None] | None = None,
    compare: str = "auto",
) -> FitResult:
    """Fit `parameters` of `task`'s planning model to `episodes` over windows of `window_steps` steps.

    `compare` (sysid_data.COMPARE_CHOICES) says what the model's predictions are compared with: the logged plant
    states, or the task's measured sensors as the plant reported them (the sensordata mujoco.sysid rolls out,
    at the steps they were taken), each window then starting from the logged estimate where there is one; auto
    takes the sensors where every episode holds them.

    With DELAY_PARAMETER among them, also the actuation delay (s, within [0, MAX_DELAY]): every window's logged
    actions take effect that late (`delayed_controls`), read from the actions before it. Each parameter starts at
    the planning model's value (the first entry of its row, or entry `index`) and is bounded to [value / 10,
    value * 10] (to [0, 1] where the model holds 0); a position (a field ending in "pos", e.g. body_ipos, a body's
    centre of mass) to value ± POSITION_SPAN, since it may cross 0. `on_evaluation(n)` is called after the n-th
    evaluation of the residual (a progress bar).
    """
    sysid = import_extra("mujoco.sysid", "python -m judo sysid", EXTRA)
    if not hasattr(sysid, "optimize"):  # mujoco.sysid swallows its own ImportError
        import_extra("scipy", "python -m judo sysid", EXTRA)
        import_extra("colorama", "python -m judo sysid", EXTRA)
    absl = logging.getLogger("absl")  # mujoco.sysid's warnings (a sensor layout it does not use) stay quiet
    level = absl.level
    absl.setLevel(logging.ERROR)
    try:
        return _fit(sysid, task, parameters, episodes, window_steps, max_iters, on_evaluation, compare)
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
) -> FitResult:
    began = time.perf_counter()
    model = task.model
    timestep = float(model.opt.timestep)
    delay_at = next((i for i, p in enumerate(parameters) if p.field == DELAY), None)
    history = int(np.ceil(MAX_DELAY / timestep)) + 1 if delay_at is not None else 0
    compare = compared(episodes, compare)
    windows = cut_windows(episodes, window_steps, history, compare, task.measured, timestep)
    nominal = np.array([0.0 if p.field == DELAY else _entry(model, p) for p in parameters])
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
                (value / 10, value * 10) if value > 0 else ((0.0, 1.0) if value == 0 else (value * 10, value / 10))
            )
            start = value
        bounds.append((low, high, start))

    def build_model(candidate: Any) -> mujoco.MjModel:
        return fitted_model(model, parameters, np.array([candidate[p.name].value[0] for p in parameters]))

    params = sysid.ParameterDict()
    for parameter, (low, high, start) in zip(parameters, bounds, strict=True):
        params.add(sysid.Parameter(parameter.name, nominal=start, min_value=low, max_value=high))
    sequences = model_sequences(sysid, model, windows)
    if compare == "sensors":  # each candidate's windows start where its own motion best explains their measurements
        rollout = refined_rollout(sysid, model, windows, DELAY if delay_at is not None else None)
    else:
        rollout = delayed_rollout(sysid, model, windows, DELAY) if delay_at is not None else None
    residual = batched_residual(
        sysid, sequences.measured_rollout, build_model, observed_residual(sysid, spread(windows), windows.columns),
        rollout,
    )  # fmt: skip
    evaluations = [0]

    def counted(x: np.ndarray, candidate: Any, **kwargs: Any) -> Any:
        evaluations[0] += 1
        if on_evaluation is not None:
            on_evaluation(evaluations[0])
        return residual(x, candidate, **kwargs)

    with contextlib.redirect_stdout(io.StringIO()):
        opt_params, result = sysid.optimize(
            params, counted, optimizer="mujoco", verbose=False, max_iters=max_iters, x_scale=scale, output=io.StringIO()
        )
        fitted = np.array([opt_params[p.name].value[0] for p in parameters])
        residuals, _, _ = residual(fitted, opt_params)
        jacobian = np.asarray(result.jac, dtype=float)
        _, interval = sysid.calculate_intervals(residuals, jacobian)
    scaled = jacobian * scale[None, :]
    condition = float(np.linalg.cond(scaled)) if scaled.size else float("inf")
    interval = np.asarray(interval, dtype=float)
    size = np.maximum(np.abs(fitted), 1e-12)
    size[positions] = np.maximum(size[positions], POSITION_SCALE)
    if delay_at is not None:  # a delay near 0 is determined when known to within a quarter of a step
        size[delay_at] = max(size[delay_at], timestep)
    excited = np.isfinite(interval) & (interval <= EXCITED_REL_INTERVAL * size)
    delay = float(fitted[delay_at]) if delay_at is not None else 0.0
    return FitResult(
        parameters,
        nominal,
        fitted,
        interval,
        excited,
        condition,
        refined_prediction_error(model, windows, 0.0),
        refined_prediction_error(fitted_model(model, parameters, fitted), windows, delay),
        len(windows.starts),
        window_steps,
        time.perf_counter() - began,
        compare,
        windows.from_estimate,
        timestep,
    )


def _entry(model: mujoco.MjModel, parameter: FitParameter) -> float:
    return float(model_value(model, parameter.field, parameter.element)[parameter.index or 0])
