"""Risk measures: each control sequence's rewards under several randomized models, reduced to one
score.

Every function takes rewards of shape (num_rollouts, num_randomizations), one row per sampled
control sequence and one column per model it was rolled out under, and returns (num_rollouts,).
Higher is better, as everywhere in judo. NaN counts as -inf (a diverged rollout), so "average",
"worst", "cvar" and a risk-averse "exponential" score a sequence -inf if any of its models diverged;
"best" and a risk-seeking "exponential" look past it.
"""

from typing import Literal, get_args

import numpy as np

from judo.core.errors import UnknownNameError

RiskMeasure = Literal["average", "worst", "best", "cvar", "exponential"]
"""How rewards under several models are reduced: mean, min, max, mean of the worst alpha fraction
(conditional value at risk), or the exponential utility's certainty equivalent."""

RISK_MEASURES: tuple[str, ...] = get_args(RiskMeasure)


def nan_to_neg_inf(rewards: np.ndarray) -> np.ndarray:
    """A float copy of `rewards` (any shape) with NaN replaced by -inf."""
    rewards = np.array(rewards, dtype=float)
    rewards[np.isnan(rewards)] = -np.inf
    return rewards


def average(rewards: np.ndarray) -> np.ndarray:
    """(num_rollouts, R) -> (num_rollouts,) mean over the R models."""
    return nan_to_neg_inf(rewards).mean(axis=1)


def worst(rewards: np.ndarray) -> np.ndarray:
    """(num_rollouts, R) -> (num_rollouts,) minimum over the R models."""
    return nan_to_neg_inf(rewards).min(axis=1)


def best(rewards: np.ndarray) -> np.ndarray:
    """(num_rollouts, R) -> (num_rollouts,) maximum over the R models."""
    return nan_to_neg_inf(rewards).max(axis=1)


def cvar(rewards: np.ndarray, alpha: float) -> np.ndarray:
    """(num_rollouts, R) -> (num_rollouts,) mean of each row's ceil(alpha * R) lowest rewards.

    `alpha` in (0, 1]: 1 is the average, alpha <= 1 / R the worst case.
    """
    rewards = nan_to_neg_inf(rewards)
    count = max(1, int(np.ceil(alpha * rewards.shape[1] - 1e-9)))
    return np.sort(rewards, axis=1)[:, :count].mean(axis=1)


def exponential(rewards: np.ndarray, scale: float) -> np.ndarray:
    """(num_rollouts, R) -> (num_rollouts,) certainty equivalent -1/scale * log(mean_r exp(-scale *
    reward_r)).

    `scale` > 0 is risk-averse (towards the worst case as it grows), < 0 risk-seeking (towards the
    best), and tends to the average as it nears 0. Its units are 1 / reward: pick it against the
    spread of the task's rewards. Computed as a shifted log-sum-exp, so large scales do not
    overflow.
    """
    if scale == 0:
        raise ValueError("exponential risk needs a nonzero scale")
    rewards = nan_to_neg_inf(rewards)
    exponents = -scale * rewards  # (num_rollouts, R)
    shift = exponents.max(axis=1, keepdims=True)
    finite_shift = np.where(np.isfinite(shift), shift, 0.0)
    with np.errstate(invalid="ignore", over="ignore"):
        log_mean = np.log(np.exp(exponents - finite_shift).mean(axis=1)) + finite_shift[:, 0]
    log_mean[np.isposinf(shift[:, 0])] = np.inf  # a -inf reward dominates a risk-averse measure
    return -log_mean / scale


def reduce_rewards(
    rewards: np.ndarray, measure: str, cvar_alpha: float = 0.5, risk_scale: float = 1.0
) -> np.ndarray:
    """(num_rollouts, R) rewards -> (num_rollouts,) scores by the risk `measure` (one of
    RISK_MEASURES).

    `cvar_alpha` is read by "cvar", `risk_scale` by "exponential". NaN counts as -inf.
    Raises UnknownNameError for an unknown measure.
    """
    if rewards.ndim != 2:
        raise ValueError(
            f"rewards must have shape (num_rollouts, num_randomizations), got {rewards.shape}"
        )
    if measure == "average":
        return average(rewards)
    if measure == "worst":
        return worst(rewards)
    if measure == "best":
        return best(rewards)
    if measure == "cvar":
        return cvar(rewards, cvar_alpha)
    if measure == "exponential":
        return exponential(rewards, risk_scale)
    raise UnknownNameError("risk measure", measure, RISK_MEASURES)
