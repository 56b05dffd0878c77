"""How much of a log a sysid fit explains (judo.sysid.fit): windows held out of the fit, the
prediction error measurement noise alone would leave, whether the fitted model explains the rest,
and, where it does not, the parameters not fitted that would explain most of it.
"""

import math

import mujoco
import numpy as np

from judo.core.configuration.model_overrides import model_value, overridden
from judo.core.errors import JudoError
from judo.sysid.hooks import refined_residuals
from judo.sysid.windows import Windows

HOLD_OUT_EVERY = 5
"""Every HOLD_OUT_EVERY-th window is held out of the fit, to report the fitted model's error on
windows it never saw."""
NOISE_MARGIN = 2.0
"""A prediction error within this factor of the measurement noise's (`noise_floor`) is the noise:
nothing is left for a parameter to explain."""
MIN_REMOVED = 0.5
"""The least share of the prediction error above the noise a fit must remove to call its parameters
determined."""
EXACT = 1e-9
"""A prediction error (in spreads) below this is exact whatever the noise estimate."""
MIN_GAIN = 0.1
"""The least share of the remaining squared error a missing parameter must remove to first order to
be named."""


def at_noise(error: float, noise: float) -> bool:
    """Whether a prediction error is the noise's: within NOISE_MARGIN of `noise`, or below EXACT."""
    return error <= max(NOISE_MARGIN * noise, EXACT)


def explains(before: float, after: float, noise: float) -> bool:
    """Whether a fitted model whose prediction error is `after` (the planning model's: `before`; the
    noise's: `noise`) explains the log: its error is at the noise (within NOISE_MARGIN of it, or
    EXACT), or the fit removed at least MIN_REMOVED of the error above the noise. Where not, the
    model lacks something the fitted parameters cannot stand in for, and their intervals (which take
    what is left for noise) do not hold."""
    if at_noise(after, noise):
        return True
    above_before = math.sqrt(max(before**2 - noise**2, 0.0))
    above_after = math.sqrt(max(after**2 - noise**2, 0.0))
    return above_after <= (1.0 - MIN_REMOVED) * above_before


def split_windows(windows: Windows, every: int) -> tuple[Windows, Windows | None]:
    """(training, held out): every `every`-th window (the last of each `every`) held out, the rest
    to fit; None held out where there are fewer than `every` windows."""
    from dataclasses import replace

    held = np.arange(len(windows.starts)) % every == every - 1
    if not held.any():
        return windows, None

    def part(rows: np.ndarray) -> Windows:
        return replace(
            windows,
            starts=windows.starts[rows],
            controls=windows.controls[rows],
            measured=windows.measured[rows],
            history=windows.history[rows],
        )

    return part(~held), part(held)


def noise_floor(residuals: np.ndarray) -> float:
    """The RMS that measurement noise alone would leave in (W, K, D) `residuals`, estimated from
    their scatter from step to step: each coordinate's second differences along the window (of three
    consecutive compared steps; a model's error drifts smoothly, white noise does not) give its
    noise as 1.4826 * median(|d2|) / sqrt(6), and the coordinates are pooled as `rms` weighs them. 0
    where no three consecutive steps were compared."""
    second = residuals[:, 2:] - 2 * residuals[:, 1:-1] + residuals[:, :-2]  # (W, K - 2, D)
    total, counted = 0.0, 0
    for coordinate in range(residuals.shape[-1]):
        values = second[..., coordinate][np.isfinite(second[..., coordinate])]
        samples = int(np.isfinite(residuals[..., coordinate]).sum())
        if len(values):
            total += samples * (1.4826 * float(np.median(np.abs(values))) / np.sqrt(6.0)) ** 2
            counted += samples
    return float(np.sqrt(total / counted)) if counted else 0.0


def first_order_gains(
    model: mujoco.MjModel,
    windows: Windows,
    delay: float,
    fitted: list[tuple[str, str, int]],
    candidates: list[tuple[str, str, int]],
) -> np.ndarray:
    """(C,) for each candidate parameter (field, element, index) of `model` (the fitted one), the
    share of its remaining squared prediction error on `windows` that one Gauss-Newton step on that
    parameter, beside the `fitted` ones (whose directions are projected out), would remove: (j.r)^2
    / (|j|^2 |r|^2) for the residual r (`refined_residuals`) and its derivative j by a forward
    difference, the fitted columns taken out of j. NaN for a candidate whose nudged model cannot be
    built."""
    base = np.nan_to_num(refined_residuals(model, windows, delay).reshape(-1))

    def column(field: str, element: str, index: int) -> np.ndarray | None:
        row = model_value(model, field, element).copy()
        size = 1.0 if index < 0 else abs(row[index])  # index -1: a factor scaling the whole row
        step = 1e-3 * size if size != 0 else 1e-4
        # the other way where the nudge leaves what MuJoCo can simulate
        for signed in (step, -step):
            nudged = row * (1.0 + signed) if index < 0 else row.copy()
            if index >= 0:
                nudged[index] += signed
            try:
                candidate = overridden(model, {field: {element: nudged}})
            except JudoError:
                continue
            return (
                np.nan_to_num(refined_residuals(candidate, windows, delay).reshape(-1)) - base
            ) / signed
        return None

    known = [c for c in (column(*p) for p in fitted) if c is not None]
    basis = np.linalg.qr(np.stack(known, axis=1))[0] if known else np.zeros((len(base), 0))
    energy = float(base @ base)
    gains = np.full(len(candidates), np.nan)
    for at, parameter in enumerate(candidates):
        j = column(*parameter)
        if j is None or energy == 0.0:
            continue
        j = j - basis @ (basis.T @ j)
        size = float(j @ j)
        gains[at] = (float(j @ base) ** 2 / (size * energy)) if size > 0 else 0.0
    return gains


def likely_missing(
    model: mujoco.MjModel, windows: Windows, delay: float, fitted: list[tuple[str, str, int]]
) -> list[tuple[str, float]]:
    """[(name, share)] of the `missing_candidates` of the fitted `model` (its parameters `fitted`)
    whose `first_order_gains` on `windows` reach MIN_GAIN, largest first, at most three."""
    candidates = missing_candidates(model, fitted)
    gains = first_order_gains(model, windows, delay, fitted, [c[:3] for c in candidates])
    named = [(c[3], float(g)) for c, g in zip(candidates, gains, strict=True) if g >= MIN_GAIN]
    return sorted(named, key=lambda item: -item[1])[:3]


def missing_candidates(
    model: mujoco.MjModel, fitted: list[tuple[str, str, int]]
) -> list[tuple[str, str, int, str]]:
    """[(field, element, index, name)] of parameters not among `fitted` (index -1: a whole row's
    factor) that most often explain what a fit leaves: the mass, inertia (its row scaled as one: a
    heavier part of the same shape) and centre of mass of each body a body_* parameter names, and
    the damping and armature of every hinge and slide joint."""
    bodies = sorted({element for field, element, _ in fitted if field.startswith("body_")})
    keys = [
        (field, body, index)
        for body in bodies
        for field, index in (("body_mass", 0), ("body_inertia", -1))
    ]
    keys += [("body_ipos", body, i) for body in bodies for i in range(3)]
    for joint in range(model.njnt):
        if model.jnt_type[joint] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            keys += [
                ("dof_damping", model.joint(joint).name, 0),
                ("dof_armature", model.joint(joint).name, 0),
            ]
    rows, whole_rows = {key[:2] for key in fitted}, {key[:2] for key in fitted if key[2] < 0}
    named = []
    for field, element, index in keys:
        if (
            (field, element, index) in fitted
            or (field, element) in whole_rows
            or (index < 0 and (field, element) in rows)
        ):
            continue
        whole = model_value(model, field, element).size == 1 or index < 0
        named.append(
            (field, element, index, f"{field}.{element}" + ("" if whole else f"[{index}]"))
        )
    return named
