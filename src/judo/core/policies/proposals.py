"""The policy as a proposal (generative predictive control): some of an update's candidates come
from a policy.

With `ControllerConfig.policy_samples` K > 0, every optimizer iteration overwrites the last K of the
optimizer's N sampled knot sequences with candidates made from the controller's `proposal_policy`,
before the clamp and the rollouts, so the optimizer scores and ranks them with its own:

  - a chunk policy (horizon H > 1) gives knots directly: its chunk is read as H values evenly spaced
    over the planning horizon, which is the plan's knots when H == num_nodes and is otherwise
    interpolated linearly onto the num_nodes knot times;
  - an action policy (H = 1) is rolled out in closed loop on the planning model from the current
    state (T steps, one batched `act` per step for all K rollouts, then one at the final state for
    the horizon's end), and its T + 1 actions are fitted to the knots by least squares on the
    spline's weights.

The policy runs once per update, on K copies of the observation: a generative (stochastic) policy
gives K samples, a deterministic one K equal ones. Candidate 0 goes in as it is; candidate j >= 1 is
moved by the perturbation the optimizer drew for the row it replaces (that row minus the nominal,
row 0), so the copies of a deterministic policy explore around it with the optimizer's own current
spread (CEM's sigma, DIAL's annealing, CMA-ES's covariance) and no new setting. Nothing here draws
from the optimizer's generator, so the other N - K candidates are the same draws, bit for bit, as
the same seed's without proposals.

What the policy sees is the task's `policy_observation(states, sensors, system_metadata,
previous_actions)`. On a task that plans a low-level policy's commands (`Task.low_level`), the
candidates are commands (`command_size`, clamped to `command_range`), and only a chunk policy can
propose: an action policy's closed loop here steps the actuators directly, which would bypass the
low-level policy.
"""

import warnings
from typing import Any

import mujoco
import mujoco.rollout
import numpy as np

from judo.core.errors import ConfigError
from judo.core.policy import Policy, PolicyError
from judo.core.reading import mocap_metadata, model_at
from judo.core.rollouts.stepper import PolicyStepper
from judo.core.spline import MIN_KNOTS, SplineBasis, SplineOrder
from judo.core.task import Task


def chunk_to_knots(
    chunks: np.ndarray, knot_offsets: np.ndarray, order: SplineOrder = "linear"
) -> np.ndarray:
    """(K, num_nodes, nu) knots from (K, H, nu) chunks whose H values are knots spread evenly over
    [0, knot_offsets[-1]] (as the policy as the controller serves them): the chunks themselves when
    H == num_nodes, else their `order` spline (linear when H is too few knots for it) at the
    (num_nodes,) offsets."""
    horizon = chunks.shape[1]
    if horizon == len(knot_offsets):
        return chunks
    chunk_times = np.linspace(0.0, knot_offsets[-1], horizon)
    order = order if horizon >= MIN_KNOTS[order] else "linear"
    return SplineBasis(chunk_times, order).weights(knot_offsets) @ chunks


def fit_times(num_steps: int, dt: float, horizon: float) -> np.ndarray:
    """(T + 1,) times of a closed-loop rollout's actions: each step's start, j * dt, then the
    horizon's end."""
    return np.append(np.arange(num_steps) * dt, horizon)


def fit_matrix(basis: SplineBasis, num_steps: int, dt: float) -> np.ndarray:
    """(num_nodes, T + 1) least-squares map from actions at `fit_times` to the knots of `basis`
    whose spline is closest to them: the pseudo-inverse of the spline's (T + 1, num_nodes) weights
    at those times (a knot no time weighs, too few steps per knot, gets the minimum-norm value
    0)."""
    return np.linalg.pinv(basis.weights(fit_times(num_steps, dt, basis.knot_times[-1])))


def insert_proposals(knots: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """Overwrite the last K rows of the (N, num_nodes, nu) `knots` in place with the (K, num_nodes,
    nu) `candidates`: candidate 0 as it is, candidate j >= 1 plus the replaced row's offset from row
    0 (the nominal). Returns the (K,) replaced rows."""
    num_rollouts, count = len(knots), len(candidates)
    rows = np.arange(num_rollouts - count, num_rollouts)
    offsets = knots[rows[1:]] - knots[0]
    knots[rows[0]] = candidates[0]
    knots[rows[1:]] = candidates[1:] + offsets
    return rows


def check_proposal_policy(policy: Policy | None, policy_samples: int) -> None:
    """ConfigError (one line) when `policy_samples` > 0 proposals are asked for and there is no
    `policy`."""
    if policy_samples and policy is None:
        raise ConfigError(
            f"policy_samples is {policy_samples} but the controller has no proposal policy; "
            "give one "
            "(make_controller(..., proposal_policy=...), evaluate --proposal-policy "
            "FILE.onnx) or set it to 0"
        )


def check_policy_fits(task: Task, policy: Policy, task_name: str | None = None) -> None:
    """PolicyError (one line, naming both sides) unless `policy` was made for `task_name` (when both
    say) and takes the task's `policy_observation` to the plan's command_size values; and, on a task
    that plans a low-level policy's commands, unless it is a chunk policy (an action policy's closed
    loop runs the actuators, not the low-level policy)."""
    policy.check_fits(task_name, task.policy_observation_size(), task.command_size)
    if policy.horizon == 1 and task.low_level() is not None:
        raise PolicyError(
            f"policy {policy.name!r} is an action policy, but {type(task).__name__} plans a "
            "low-level policy's "
            "commands, where only a chunk policy (horizon > 1) can propose; its closed loop "
            "would bypass the low-level policy"
        )


class Proposer:
    """Makes a proposal policy's candidates for a controller, once per update (see the module
    docstring).

    Holds what it reuses between updates: an MjData for the initial sensors, a rollout runner, and
    the least-squares fit matrix of the spline layout in force. A policy that fails during an update
    (raises PolicyError: non-finite actions, another shape) costs that update its proposals, not its
    plan: the optimizer's own N samples run, a RuntimeWarning says why, and `last_error` keeps the
    message.

    Made with the controller's `policy` and `count` (its policy_samples), which are checked at once
    (see `check`).

    Attributes:
        last_error: why the last update went without proposals, or None when it had them (or asked
            for none).
    """

    def __init__(self, task: Task, policy: Policy | None = None, count: int = 0) -> None:
        self.task = task
        model = task.model
        # made at the first proposal: most controllers never propose
        self._data: mujoco.MjData | None = None
        self._runner: mujoco.rollout.Rollout | None = None
        self._stepper: PolicyStepper | None = None
        self._num_state = model.nq + model.nv
        self._fit_key: tuple | None = None
        self._fit = np.zeros((0, 0))
        self._checked: tuple[Policy, int] | None = None
        self.last_error: str | None = None
        self.check(policy, count)

    def check(self, policy: Policy | None, count: int) -> None:
        """ConfigError (one line) when `count` > 0 proposals are asked for and there is no `policy`;
        PolicyError unless a `policy` takes the task's observations to its nu controls (checked once
        per policy)."""
        check_proposal_policy(policy, count)
        if policy is None or (
            self._checked is not None
            and self._checked[0] is policy
            and self._checked[1] == self.task.command_size
        ):
            return
        check_policy_fits(self.task, policy)
        self._checked = (policy, self.task.command_size)

    def candidates(
        self,
        policy: Policy | None,
        count: int,
        initial_state: np.ndarray,
        initial_mocap: np.ndarray,
        basis: SplineBasis,
        num_steps: int,
        system_metadata: dict[str, Any] | None,
        previous_action: np.ndarray,
    ) -> np.ndarray | None:
        """(count, num_nodes, nu) the policy's candidate knots from the full physics `initial_state`
        (nstate,) with mocap poses `initial_mocap` (7 nmocap,), for the spline `basis` over
        `num_steps` steps; not clamped. `previous_action` (nu,) is the action the plant gets now
        (what the policy's first observation holds as its previous action, where the task's
        observation has one). None when `count` is 0; ConfigError when it is not and there is no
        policy (see `check`)."""
        self.check(policy, count)
        self.last_error = None
        if not count or policy is None:
            return None
        try:
            # a deterministic policy's candidates from one start are one candidate, repeated
            made = 1 if policy.deterministic else count
            start = (initial_state, initial_mocap, np.tile(previous_action, (made, 1)))
            knots = self._candidates(policy, made, start, basis, num_steps, system_metadata)
            return knots if made == count else np.repeat(knots, count, axis=0)
        except PolicyError as err:
            self.last_error = str(err)
            warnings.warn(
                f"this update runs without proposals: {err}", RuntimeWarning, stacklevel=3
            )
            return None

    def _candidates(
        self,
        policy: Policy,
        count: int,
        start: tuple[np.ndarray, np.ndarray, np.ndarray],
        basis: SplineBasis,
        num_steps: int,
        system_metadata: dict[str, Any] | None,
    ) -> np.ndarray:
        initial_state, initial_mocap, previous = start
        model = self.task.model
        data = self._data
        if data is None:
            data = self._data = mujoco.MjData(model)
            self._runner = mujoco.rollout.Rollout(nthread=0)
        # the initial sensors, on the MjData the closed loop's runner steps (its ctrl and warm start
        # as it left them)
        model_at(model, data, initial_state, metadata=mocap_metadata(model, initial_mocap))
        states = np.tile(initial_state[1 : 1 + self._num_state], (count, 1))
        sensors = np.tile(data.sensordata, (count, 1))
        observations = self._observe(states, sensors, system_metadata, previous)
        if policy.horizon > 1:
            return chunk_to_knots(policy.checked_act(observations), basis.knot_times, basis.order)
        actions = self._closed_loop(
            policy, count, initial_state, initial_mocap, num_steps, observations, system_metadata
        )
        key = (tuple(basis.knot_times), basis.order, num_steps, self.task.dt)
        if key != self._fit_key:
            self._fit, self._fit_key = fit_matrix(basis, num_steps, self.task.dt), key
        return np.einsum("nt,kta->kna", self._fit, actions)

    def _observe(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        system_metadata: dict[str, Any] | None,
        previous: np.ndarray,
    ) -> np.ndarray:
        """(B, O) the task's `policy_observation` of (B, nq + nv) states, (B, nsensordata) sensors
        and (B, nu) previous actions."""
        return np.asarray(
            self.task.policy_observation(states, sensors, system_metadata, previous), dtype=float
        )

    def _closed_loop(
        self,
        policy: Policy,
        count: int,
        initial_state: np.ndarray,
        initial_mocap: np.ndarray,
        num_steps: int,
        observations: np.ndarray,
        system_metadata: dict[str, Any] | None,
    ) -> np.ndarray:
        """(count, T + 1, nu) the action policy's actions along `count` closed-loop rollouts of T
        steps on the planning model, clamped to the ctrlrange as the plant would get them, and its
        action at the end."""
        # made by _candidates, the only caller
        assert self._runner is not None and self._data is not None
        model, nu, runner, data = self.task.model, self.task.nu, self._runner, self._data
        low, high = self.task.actuator_ctrlrange.T
        if self._stepper is None:
            self._stepper = PolicyStepper(model, nu)  # one step per tick, the action held for it
        stepper, num_state = self._stepper, self._num_state
        # the mocap poses held as inputs
        stepper.start(count, num_steps, initial_state, initial_mocap)
        actions = np.zeros((count, num_steps + 1, nu))
        models = [model] * count  # skip_checks wants one per rollout

        def observe(
            rows: slice, start: int, current: np.ndarray, previous: np.ndarray
        ) -> np.ndarray:
            if start == 0:
                return observations  # at the initial state, made by the caller
            sensors = stepper.sensors[1][:, -1]
            return self._observe(current[:, 1 : 1 + num_state], sensors, system_metadata, previous)

        def act(rows: slice, observations: np.ndarray) -> np.ndarray:
            """(K, 1, nu) the policy's actions, clamped to the ctrlrange as the plant would get
            them."""
            return np.minimum(np.maximum(policy.checked_act(observations)[:, :1], low), high)

        def physics(
            initial: np.ndarray,
            inputs: np.ndarray,
            spec: int,
            states: np.ndarray,
            sensors: np.ndarray,
        ):
            runner.rollout(
                models, [data], initial, inputs, control_spec=spec, skip_checks=True,
                nstep=1, state=states, sensordata=sensors,
            )  # fmt: skip

        def record(rows: slice, start: int, stop: int) -> None:
            actions[:, start] = stepper.previous

        stepper.run(slice(0, count), observe, act, physics, record)
        final = observe(slice(0, count), num_steps, stepper.current, stepper.previous)
        actions[:, num_steps] = act(slice(0, count), final)[:, 0]
        return actions
