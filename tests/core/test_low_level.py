"""A low-level policy inside every rollout: the chunked, batched rollout equals a plain mj_step loop
bit for bit, the policy is called once per tick for all rollouts, sizes are checked at construction,
and the plant runs it."""

import math

import mujoco
import numpy as np
import pytest

import judo
from judo.core.model import STATE_SPEC
from judo.core.policy import Policy, PolicyError
from judo.core.rollouts.backend import RolloutBackend
from judo.core.rollouts.low_level import LowLevel
from judo.core.rollouts.low_level_rollout import (
    LowLevelBackendError,
    LowLevelRollout,
    with_low_level,
)
from judo.core.rollouts.rollout import RolloutPool
from judo.loop.system import MujocoSystem
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig

# A cart on a limited rail (its limit is active in the test's states, so the solver has work) and a
# pole.
LIMITED_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="cart">
      <joint name="slider" type="slide" axis="1 0 0" range="-0.3 0.3" limited="true"/>
      <geom type="box" size=".2 .1 .1" mass="1" contype="0" conaffinity="0"/>
      <body name="pole">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.6" size=".04" mass=".1" contype="0" conaffinity="0"/>
        <site name="tip" pos="0 0 0.6"/>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="slider" gear="10" ctrlrange="-1 1" ctrllimited="true"/></actuator>
  <sensor><framepos name="trace_tip" objtype="site" objname="tip"/></sensor>
</mujoco>
"""  # noqa: E501


class RowwiseLinear(Policy):
    """tanh(W obs + b), each row computed alone (so a batch of one gives the same bits as a row of a
    batch of N); counts its calls and their batch sizes."""

    def __init__(self, weight: np.ndarray, bias: np.ndarray) -> None:
        self.weight, self.bias = np.asarray(weight, float), np.asarray(bias, float)
        self.action_size, self.observation_size = self.weight.shape
        self.metadata = {"name": "rowwise_linear"}
        self.batches: list[int] = []

    def act(self, observations: np.ndarray) -> np.ndarray:
        self.batches.append(len(observations))
        out = np.tile(self.bias, (len(observations), 1))
        for j in range(self.observation_size):
            out += observations[:, j : j + 1] * self.weight[:, j]
        return np.tanh(out)[:, None, :]  # (B, 1, A): a per-step policy's chunk of one


def with_previous(commands, states, previous_actions, times):
    """[commands, states, previous actions, sim time]: O = C + nq + nv + A + 1."""
    return np.concatenate([commands, states, previous_actions, times[:, None]], axis=1)


def make_low_level(every: int, seed: int = 0) -> LowLevel:
    rng = np.random.default_rng(seed)
    policy = RowwiseLinear(rng.normal(0.0, 1.0, (2, 2 + 4 + 2 + 1)), rng.normal(0.0, 0.1, 2))
    return LowLevel(
        policy,
        command_range=[[-0.5, 0.5], [-1.0, 1.0]],
        every=every,
        observation=with_previous,
        to_ctrl=to_ctrl,
    )


def to_ctrl(actions):
    """(B, 2) actions -> (B, 1) ctrl: their difference."""
    return actions[:, :1] - 0.5 * actions[:, 1:]


def reference(model, low, initial_state, commands):
    """One rollout at a time: mj_step per step, the policy on a batch of one every k steps (and, as
    MuJoCo's rollout does at the start of each chunk, a cold solver start)."""
    data = mujoco.MjData(model)
    num_rollouts, num_steps, _ = commands.shape
    states = np.zeros((num_rollouts, num_steps, mujoco.mj_stateSize(model, STATE_SPEC)))
    sensors = np.zeros((num_rollouts, num_steps, model.nsensordata))
    for i in range(num_rollouts):
        mujoco.mj_setState(model, data, initial_state, STATE_SPEC)
        previous = np.zeros((1, low.policy.action_size))
        for t in range(num_steps):
            if t % low.every == 0:
                state = np.concatenate([data.qpos, data.qvel])[None]
                times = np.array([data.time])
                previous = low.policy.act(
                    low.observe(commands[i : i + 1, t], state, previous, times)
                )[:, 0]
                data.ctrl[:] = low.ctrl(previous)[0]
                data.qacc_warmstart[:] = 0.0
            mujoco.mj_step(model, data)
            mujoco.mj_getState(model, data, states[i, t], STATE_SPEC)
            sensors[i, t] = data.sensordata
    return states, sensors


@pytest.fixture
def limited_model():
    return mujoco.MjModel.from_xml_path(_write(LIMITED_XML))


def _write(xml: str) -> str:
    import tempfile

    with tempfile.NamedTemporaryFile("w", suffix=".xml", delete=False) as f:
        f.write(xml)
    return f.name


def initial_state_of(model, qpos, qvel):
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    state = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, state, STATE_SPEC)
    return state


@pytest.mark.parametrize(("num_workers", "every"), [(1, 1), (2, 3), (3, 4)])
def test_hierarchical_rollout_equals_a_plain_loop_bit_for_bit(limited_model, num_workers, every):
    low = make_low_level(every)
    # driven into the rail's limit
    initial_state = initial_state_of(limited_model, [0.28, 2.5], [0.8, -0.2])
    # 41 steps: a short last chunk for k = 3, 4
    commands = np.random.default_rng(1).uniform(-1, 1, (7, 41, 2))
    expected_states, expected_sensors = reference(limited_model, low, initial_state, commands)
    low.policy.batches.clear()

    with LowLevelRollout(RolloutPool(limited_model, num_workers), low) as backend:
        states, sensors = backend.rollout(initial_state, commands)
        np.testing.assert_array_equal(states, expected_states)
        np.testing.assert_array_equal(sensors, expected_sensors)
        # One batched act per tick for each worker's block of rows (all 7 on one worker), never 7
        # calls of one.
        blocks = [rows.stop - rows.start for rows in backend.inner.blocks(7)]
        assert len(blocks) == num_workers and sum(blocks) == 7
        assert sorted(low.policy.batches) == sorted(blocks * math.ceil(41 / every))
        assert backend.act_calls == num_workers * math.ceil(41 / every)
    assert not np.allclose(states[0], states[1])  # different commands gave different rollouts
    assert np.abs(states[..., 1]).max() >= 0.3 - 1e-3  # the rail's limit was reached


def test_a_hook_that_takes_out_writes_each_tick_s_buffer_and_changes_no_bit(limited_model):
    """A hook with an `out` keyword is handed its block's rows of the stepper's (N, O) buffer in the
    rollouts (None where it is tried on a batch of one), and the rollouts are the plain loop's bit
    for bit."""
    handed: list[np.ndarray | None] = []

    def into_buffer(commands, states, previous_actions, times, out=None):
        handed.append(out)
        if out is None:
            return with_previous(commands, states, previous_actions, times)
        out[:, :2], out[:, 2:6], out[:, 6:8], out[:, 8] = commands, states, previous_actions, times
        return out

    plain = make_low_level(3)
    low = LowLevel(plain.policy, plain.command_range, 3, into_buffer, to_ctrl)
    initial_state = initial_state_of(limited_model, [0.28, 2.5], [0.8, -0.2])
    commands = np.random.default_rng(2).uniform(-1, 1, (6, 20, 2))
    expected_states, expected_sensors = reference(limited_model, plain, initial_state, commands)
    with LowLevelRollout(RolloutPool(limited_model, 2), low) as backend:
        assert handed == [None]  # `check`, as the backend is built, tries it on a batch of one
        states, sensors = backend.rollout(initial_state, commands)
        buffer = backend._stepper.observations
    np.testing.assert_array_equal(states, expected_states)
    np.testing.assert_array_equal(sensors, expected_sensors)
    assert len(handed) == 1 + 2 * 7  # 7 ticks of 3 steps for each of 2 blocks
    assert all(out is not None and out.base is buffer and len(out) == 3 for out in handed[1:])


def test_non_finite_actions_make_that_rollout_nan_and_no_other(limited_model):
    class NanForNegative(Policy):
        observation_size, action_size, metadata = 6, 1, {}

        def act(self, observations):
            return np.where(observations[:, :1] < 0, np.nan, 0.1)

    low = LowLevel(NanForNegative(), command_range=[[-1.0, 1.0], [-1.0, 1.0]], every=2)
    commands = np.zeros((3, 6, 2))
    commands[1] = -1.0
    with LowLevelRollout(RolloutPool(limited_model, 1), low) as backend:
        states, sensors = backend.rollout(initial_state_of(limited_model, [0, 0], [0, 0]), commands)
    assert np.isnan(states[1]).all() and np.isnan(sensors[1]).all()
    assert np.isfinite(states[[0, 2]]).all()


class LowLevelTask(judo.Task[judo.TaskConfig]):
    """The limited cart-pole planned through `make_low_level(2)`: two commands for one actuator."""

    def __init__(self, model_path, low: LowLevel | None = None) -> None:
        super().__init__(model_path)
        self._low = low if low is not None else make_low_level(2)
        self.seen_controls: list[tuple[int, ...]] = []

    def low_level(self):
        return self._low

    def reward(self, states, sensors, controls, config, system_metadata=None):
        self.seen_controls.append(controls.shape)
        return -np.square(states[..., 1]).sum(-1)


def test_the_controller_plans_the_commands_in_their_range(tmp_path):
    path = tmp_path / "limited.xml"
    path.write_text(LIMITED_XML)
    task = LowLevelTask(path)
    assert (task.nu, task.command_size) == (1, 2)
    np.testing.assert_array_equal(task.command_range, [[-0.5, 0.5], [-1.0, 1.0]])
    optimizer = PredictiveSampling(
        PredictiveSamplingConfig(num_rollouts=8, num_nodes=3), task.command_size
    )
    with judo.Controller(
        judo.ControllerConfig(horizon=0.2), task, optimizer, num_workers=2
    ) as controller:
        assert isinstance(controller.backend, LowLevelRollout)
        controller.update_action(np.array([0.0, 0.1, 0.0, 0.0]), 0.0)
        assert controller.nominal_knots.shape == (3, 2)
        assert (np.abs(controller.nominal_knots[:, 0]) <= 0.5).all()
        assert controller.action(0.05).shape == (2,)
        assert task.seen_controls == [(8, 20, 2)]  # the reward got the commands
        # 20 steps, a tick every 2, for each of the 2 workers
        assert controller.backend.act_calls == 10 * 2


@pytest.mark.parametrize(
    ("low", "message"),
    [
        (
            LowLevel(
                RowwiseLinear(np.zeros((2, 7)), np.zeros(2)),
                [[-1, 1], [-1, 1]],
                2,
                with_previous,
                to_ctrl,
            ),
            "policy 'rowwise_linear' takes observations of size 7, but the task ? gives 9",
        ),
        (
            LowLevel(RowwiseLinear(np.zeros((2, 6)), np.zeros(2)), [[-1, 1], [-1, 1]], 2),
            "policy 'rowwise_linear' gives actions of shape (2,) per row, but the "
            "model has nu = 1 actuators",
        ),
    ],
)
def test_a_policy_that_does_not_fit_is_refused_in_one_line_at_construction(tmp_path, low, message):
    path = tmp_path / "limited.xml"
    path.write_text(LIMITED_XML)
    task = LowLevelTask(path, low)
    optimizer = PredictiveSampling(PredictiveSamplingConfig(num_rollouts=4), task.command_size)
    with pytest.raises(PolicyError) as caught:
        judo.Controller(judo.ControllerConfig(horizon=0.2), task, optimizer, num_workers=1)
    assert str(caught.value) == message and "\n" not in str(caught.value)
    with pytest.raises(PolicyError, match="horizon 1"):
        chunk = RowwiseLinear(np.zeros((1, 6)), np.zeros(1))
        chunk.horizon = 3
        LowLevel(chunk, [[-1, 1], [-1, 1]])


def test_a_backend_that_cannot_run_the_policy_is_closed_and_named(limited_model):
    class OpenLoopOnly(RolloutBackend):
        closed = False

        def __init__(self, model):
            self.model, self.num_workers = model, 1

        def rollout(self, initial_state, controls, mocap=None):
            raise AssertionError("never rolled out")

        def close(self):
            self.closed = True

    backend = OpenLoopOnly(limited_model)
    assert with_low_level(backend, None) is backend
    with pytest.raises(
        LowLevelBackendError, match="the OpenLoopOnly rollout backend cannot run a low-level policy"
    ):
        with_low_level(backend, make_low_level(2))
    assert backend.closed


def test_the_plant_runs_the_policy_on_the_served_command_every_k_steps(tmp_path):
    path = tmp_path / "limited.xml"
    path.write_text(LIMITED_XML)
    task = LowLevelTask(path, make_low_level(3))
    task.data.qpos[:] = [0.0, 0.3]
    mujoco.mj_forward(task.sim_model, task.data)
    initial_state = initial_state_of(task.sim_model, [0.0, 0.3], [0.0, 0.0])
    system = MujocoSystem(task)
    command = np.array([0.4, -0.7])
    system.apply(command)
    for _ in range(9):
        system.step()
    expected, _ = reference(
        task.sim_model, task.low_level(), initial_state, np.tile(command, (1, 9, 1))
    )
    np.testing.assert_array_equal(system.plant_state(), expected[0, -1, 1:5])
    assert task.low_level().policy.batches[-3:] == [1, 1, 1]  # ticks at steps 0, 3 and 6


def test_the_warp_backend_is_refused_before_it_is_built(tmp_path):
    path = tmp_path / "limited.xml"
    path.write_text(LIMITED_XML)
    task = LowLevelTask(path)
    optimizer = PredictiveSampling(PredictiveSamplingConfig(num_rollouts=4), task.command_size)
    with pytest.raises(
        LowLevelBackendError, match="^the warp rollout backend cannot run a low-level policy"
    ):
        judo.Controller(
            judo.ControllerConfig(horizon=0.2), task, optimizer, num_workers=1, backend="warp"
        )


def test_randomized_models_roll_out_through_the_policy_block_by_block(limited_model):
    heavier = mujoco.MjModel.from_xml_path(_write(LIMITED_XML.replace('mass=".1"', 'mass=".3"')))
    low = make_low_level(3)
    initial_state = initial_state_of(limited_model, [0.1, 2.5], [0.3, -0.2])
    commands = np.random.default_rng(2).uniform(-1, 1, (4, 10, 2))
    with LowLevelRollout(RolloutPool(limited_model, 2), low) as backend:
        backend.set_models([limited_model, heavier])
        states, _ = backend.rollout(initial_state, commands)
    np.testing.assert_array_equal(
        states[:2], reference(limited_model, low, initial_state, commands[:2])[0]
    )
    np.testing.assert_array_equal(
        states[2:], reference(heavier, low, initial_state, commands[2:])[0]
    )


MOCAP_XML = LIMITED_XML.replace(
    "  </worldbody>",
    '    <body name="goal" mocap="true" pos="0 0 1"><site name="goal"/></body>\n  </worldbody>',
).replace("<sensor>", '<sensor><framepos name="goal_pos" objtype="site" objname="goal"/>')


def test_mocap_poses_hold_through_every_chunk():
    model = mujoco.MjModel.from_xml_path(_write(MOCAP_XML))
    mocap = np.array([0.5, -0.2, 0.7, 1.0, 0.0, 0.0, 0.0])  # [pos, quat] of the one mocap body
    with LowLevelRollout(RolloutPool(model, 1), make_low_level(2)) as backend:
        _, sensors = backend.rollout(
            initial_state_of(model, [0, 0], [0, 0]), np.zeros((3, 7, 2)), mocap
        )
    np.testing.assert_allclose(sensors[..., :3], np.broadcast_to(mocap[:3], (3, 7, 3)))
