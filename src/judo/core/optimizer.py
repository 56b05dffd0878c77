"""The Optimizer contract: sample control knots around a nominal, then update the nominal from
rewards."""

import typing
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Generic, NoReturn, TypeVar

import numpy as np

from judo.core.configuration.config import Config, require_between
from judo.core.configuration.fields import slider
from judo.core.errors import JudoError, NonFiniteKnotsError

if typing.TYPE_CHECKING:
    from judo.core.task import Task

MAX_NUM_ROLLOUTS = 2**20
"""Most rollouts per iteration (a GPU backend runs 65536 and more); `check_configs` also bounds the
rollout buffers' memory, which depends on the model and horizon."""
MAX_NUM_NODES = 100
"""Most spline knots over the horizon."""
MAX_NOISE_RAMP = 100.0
"""Largest noise multiplier at the last knot."""


@slider("num_rollouts", 1, 512, 1)
@slider("num_nodes", 2, 20, 1)
@slider("noise_ramp", 0.1, 10.0, 0.1)
@dataclass
class OptimizerConfig(Config):
    """Settings every optimizer has."""

    num_rollouts: int = 32
    """Rollouts per iteration, the nominal included."""
    num_nodes: int = 4
    """Spline knots over the horizon."""
    use_noise_ramp: bool = False
    """Scale the sampling noise up along the horizon, so near-term knots move less."""
    noise_ramp: float = 2.5
    """Noise multiplier at the last knot when use_noise_ramp is on (it grows linearly from
    1/num_nodes of it)."""

    def validate(self) -> None:
        super().validate()
        require_between("num_rollouts", self.num_rollouts, 1, MAX_NUM_ROLLOUTS)
        require_between("num_nodes", self.num_nodes, 1, MAX_NUM_NODES)
        require_between("noise_ramp", self.noise_ramp, 0, MAX_NOISE_RAMP, above=True)


ConfigT = TypeVar("ConfigT", bound=OptimizerConfig)


@dataclass
class PlanningStart:
    """What one planning cycle starts from, for an optimizer that uses the model
    itself (`Optimizer.set_start`).

    Attributes:
        task: the controller's task (its planning `model`, `reward` and hooks).
        state: (nstate,) the full physics state the rollouts start
            from (judo.core.model.STATE_SPEC).
        mocap: (7 nmocap,) the mocap poses held along the rollouts [positions, quaternions].
        weights: (T, num_nodes) the spline weights: the controls of the T rollout steps
            are `weights @ knots`.
        task_config: the task config snapshot the rewards of this cycle are scored with.
        metadata: the system metadata handed to the reward (or None).
    """

    task: "Task"
    state: np.ndarray
    mocap: np.ndarray
    weights: np.ndarray
    task_config: Any
    metadata: dict[str, Any] | None


class Optimizer(ABC, Generic[ConfigT]):
    """A sampling-based update rule over spline knots.

    Attributes:
        config: the live config; edits take effect at the next planning cycle.
        nu: number of controls.
        num_rollouts, num_nodes: the sizes in use this cycle. The controller sets them from the
            config at the top of each cycle, so they stay fixed while one cycle runs.
        rng: the np.random.Generator all sampling draws from; replace it to seed.
    """

    def __init__(self, config: ConfigT, nu: int) -> None:
        self.config = config
        self.nu = nu
        self.num_rollouts = config.num_rollouts
        self.num_nodes = config.num_nodes
        self.rng = np.random.default_rng()

    @abstractmethod
    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        """Draw candidate knots around `nominal_knots` (num_nodes, nu).

        Returns a new (num_rollouts, num_nodes, nu) array; by convention entry 0 is the nominal.
        The controller clamps it to the actuator limits in place.
        """

    @abstractmethod
    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        """The new (num_nodes, nu) nominal from the clamped (num_rollouts, num_nodes, nu) samples
        and their (num_rollouts,) rewards. Rewards are finite or -inf (NaN was mapped to -inf),
        higher is better."""

    def samples_replaced(self, rows: np.ndarray, knots: np.ndarray) -> None:
        """Called after `sample_control_knots` when the controller put candidates from elsewhere (a
        proposal policy's, `ControllerConfig.policy_samples`) in place of the samples at `rows`
        (k,), never row 0, with their clamped (k, num_nodes, nu) `knots`, before the rollouts. An
        optimizer whose update reads what it drew rather than the knots it is given (CMA-ES's steps)
        brings that in line here; the default does nothing, since the other updates read only the
        knots and their rewards."""

    def set_start(self, start: PlanningStart) -> None:
        """Called once per planning cycle, before the first sample, with the state, model and spline
        the cycle plans with. Sampling optimizers need none of it (the default ignores it); a
        derivative-based one (`ilqr`) linearises the model along its nominal from there."""

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        """Called once per planning cycle before sampling, with the previous plan's (old_num_nodes,)
        knot times and this cycle's (num_nodes,) knot times. Shift or resize carried state here."""

    def restart(self) -> None:
        """Forget any search distribution carried between planning cycles (stds, means, kept
        elites).

        `Controller.reset()` calls it, so a reset plan also restarts the search. The default carries
        nothing.
        """

    def stop_cond(self) -> bool:
        """Checked after each iteration; True ends the cycle before `max_opt_iters`."""
        return False

    def noise_ramp_scale(self) -> np.ndarray:
        """(num_nodes, 1) noise multiplier per knot: ones, or the linear ramp when use_noise_ramp is
        on."""
        if not self.config.use_noise_ramp:
            return np.ones((self.num_nodes, 1))
        return self.config.noise_ramp * np.linspace(1 / self.num_nodes, 1, self.num_nodes)[:, None]

    def perturb(self, nominal_knots: np.ndarray, sigma: float | np.ndarray) -> np.ndarray:
        """(num_rollouts, num_nodes, nu): the nominal first, then the nominal plus Gaussian noise of
        std `sigma` (scalar or (num_nodes, nu)) times the noise ramp."""
        samples = np.empty((self.num_rollouts, self.num_nodes, self.nu))
        samples[0] = nominal_knots
        noise = samples[1:]  # drawn in place: the same numbers as a new array of this shape
        self.rng.standard_normal(out=noise)
        # without: ones
        noise *= sigma * self.noise_ramp_scale() if self.config.use_noise_ramp else sigma
        noise += nominal_knots
        return samples


def weighted_knots(weights: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """(num_nodes, nu) sum over i of weights[i] * knots[i], for (num_rollouts,) `weights` and
    (num_rollouts, num_nodes, nu) `knots`: the one matrix product `np.tensordot(weights, knots,
    axes=1)` makes, bit for bit, without its axis bookkeeping."""
    return np.dot(weights.reshape(1, -1), knots.reshape(len(weights), -1)).reshape(knots.shape[1:])


def sampled_knots(optimizer: Optimizer, nominal: np.ndarray, nu: int) -> np.ndarray:
    """`optimizer.sample_control_knots(nominal)`, checked: (num_rollouts, num_nodes, nu) knots.

    Raises JudoError for another shape, and NonFiniteKnotsError, after restarting the optimizer's
    search, for non-finite knots."""
    knots = optimizer.sample_control_knots(nominal)
    expected = (optimizer.num_rollouts, optimizer.num_nodes, nu)
    if knots.shape != expected:
        raise JudoError(
            f"{type(optimizer).__name__}.sample_control_knots returned shape {knots.shape}, "
            f"expected {expected}"
        )
    if not np.isfinite(knots).all():
        _restart_search(optimizer, "sample_control_knots")
    return knots


def updated_knots(optimizer: Optimizer, knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
    """`optimizer.update_nominal_knots(knots, rewards)`: the new (num_nodes, nu) nominal, checked
    (NonFiniteKnotsError, after restarting the search, for non-finite knots)."""
    nominal = optimizer.update_nominal_knots(knots, rewards)
    if not np.isfinite(nominal).all():
        _restart_search(optimizer, "update_nominal_knots")
    return nominal


def ranked_rewards(returned: Any, owner: str, rows: int, diverged: Any) -> np.ndarray:
    """(rows,) floats of what `owner`.reward `returned`, as an optimizer ranks them: NaN, +inf and
    each rollout the (rows,) `diverged` mask (or False) marks are -inf, so they never win.

    Raises JudoError, saying what came back, for what is not (rows,) numbers."""
    try:
        rewards = np.asarray(returned, dtype=float)
    except (TypeError, ValueError) as err:
        text = " ".join(str(returned).split())[:200]
        raise JudoError(
            f"{owner}.reward must return ({rows},) numbers, got {text} ({err})"
        ) from None
    if rewards.shape != (rows,):
        raise JudoError(f"{owner}.reward returned shape {rewards.shape}, expected ({rows},)")
    if diverged is not False or not np.isfinite(rewards).all():
        rewards[np.isnan(rewards) | (rewards == np.inf) | diverged] = -np.inf
    return rewards


def _restart_search(optimizer: Optimizer, method: str) -> NoReturn:
    """Restart the optimizer's search (its carried state may be NaN too) and refuse the cycle."""
    optimizer.restart()
    raise NonFiniteKnotsError(
        f"{type(optimizer).__name__}.{method} returned non-finite knots; restarted its search and "
        "kept the previous plan"
    )
