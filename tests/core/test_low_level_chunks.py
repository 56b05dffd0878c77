"""A chunk policy as a low-level policy: each tick's one batched `act` gives H knots, and every step
of the tick gets its own action off their spline, in the rollouts and on the plant alike (what
quadruped_navigate runs)."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.model import STATE_SPEC
from judo.core.policy import Policy, PolicyError
from judo.core.rollouts.low_level import LowLevel
from judo.core.rollouts.low_level_rollout import LowLevelRollout
from judo.core.rollouts.rollout import RolloutPool
from judo.core.spline import SplineBasis
from judo.loop.system import MujocoSystem

CART_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="cart">
      <joint name="slider" type="slide" axis="1 0 0"/>
      <geom type="box" size=".2 .1 .1" mass="1" contype="0" conaffinity="0"/>
      <body name="pole">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.6" size=".04" mass=".1" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="slider" gear="10" ctrlrange="-1 1" ctrllimited="true"/></actuator>
</mujoco>
"""  # noqa: E501
HORIZON, SPAN = 4, 0.3


class LinearChunk(Policy):
    """(B, O) -> (B, 4, 1) knots tanh(W_h obs): a chunk of 4 actions that differ from knot to
    knot."""

    def __init__(self, seed: int = 0, metadata: dict[str, str] | None = None) -> None:
        self.weight = np.random.default_rng(seed).normal(0.0, 0.5, (HORIZON, 5))
        self.observation_size, self.action_size, self.horizon = 5, 1, HORIZON
        self.metadata = {"name": "linear_chunk", "horizon": str(SPAN), "spline_order": "cubic"}
        if metadata is not None:
            self.metadata = metadata

    def act(self, observations: np.ndarray) -> np.ndarray:
        return np.tanh(observations @ self.weight.T)[:, :, None]


def reference(model, low, initial_state, commands):
    """One rollout at a time with mj_step: at each tick the knots of one `act`, then each step its
    own ctrl, the cubic through the knots at 0, dt, 2 dt, ... (and a cold solver start at each tick,
    as the pool's has)."""
    data = mujoco.MjData(model)
    basis = SplineBasis(np.linspace(0.0, SPAN, HORIZON), "cubic")
    num_rollouts, num_steps, _ = commands.shape
    states = np.zeros((num_rollouts, num_steps, mujoco.mj_stateSize(model, STATE_SPEC)))
    for i in range(num_rollouts):
        mujoco.mj_setState(model, data, initial_state, STATE_SPEC)
        for t in range(num_steps):
            if t % low.every == 0:
                state = np.concatenate([data.qpos, data.qvel])[None]
                observation = low.observe(
                    commands[i : i + 1, t], state, np.zeros((1, 1)), np.array([data.time])
                )
                knots = low.policy.act(observation)[0]
                tick_start = t
                data.qacc_warmstart[:] = 0.0
            data.ctrl[:] = basis.weights(np.array([(t - tick_start) * model.opt.timestep])) @ knots
            mujoco.mj_step(model, data)
            mujoco.mj_getState(model, data, states[i, t], STATE_SPEC)
    return states


@pytest.fixture
def cart(tmp_path):
    path = tmp_path / "cart.xml"
    path.write_text(CART_XML)
    return path


def initial_state_of(model):
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = [0.1, 0.4], [0.2, -0.3]
    state = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, state, STATE_SPEC)
    return state


def test_each_step_of_a_tick_takes_its_action_off_the_chunk_s_spline(cart):
    model = mujoco.MjModel.from_xml_path(str(cart))
    low = LowLevel(LinearChunk(), command_range=[[-1.0, 1.0]], every=5)
    assert low.chunk is not None and low.step_weights(5, 0.01).shape == (5, HORIZON)
    commands = np.random.default_rng(1).uniform(-1, 1, (3, 23, 1))  # 23 steps: a short last tick
    initial_state = initial_state_of(model)
    with LowLevelRollout(RolloutPool(model, 2), low) as backend:
        states, _ = backend.rollout(initial_state, commands)
        np.testing.assert_allclose(
            states, reference(model, low, initial_state, commands), rtol=1e-10, atol=1e-12
        )
        # one batched act per tick (0, 5, 10, 15, 20) for each worker's rows
        assert backend.act_calls == 5 * 2
    held = LowLevel(LinearChunk(), command_range=[[-1.0, 1.0]], every=5, chunk_spline_order="zero")
    with LowLevelRollout(RolloutPool(model, 1), held) as backend:
        zero_order, _ = backend.rollout(initial_state, commands)
        # the spline, not the first knot held, drove the steps
        assert not np.allclose(zero_order, states)


class ChunkTask(judo.Task[judo.TaskConfig]):
    def __init__(self, model_path, low: LowLevel) -> None:
        super().__init__(model_path)
        self._low = low

    def low_level(self):
        return self._low

    def reward(self, states, sensors, controls, config, system_metadata=None):
        return -np.square(states[..., 1]).sum(-1)


def test_the_plant_writes_each_step_s_action_off_the_chunk(cart):
    task = ChunkTask(cart, LowLevel(LinearChunk(), command_range=[[-1.0, 1.0]], every=5))
    model = task.sim_model
    initial_state = initial_state_of(model)
    mujoco.mj_setState(model, task.data, initial_state, STATE_SPEC)
    mujoco.mj_forward(model, task.data)
    system = MujocoSystem(task)
    system.apply(np.array([0.3]))
    ctrls = []
    for _ in range(7):
        system.step()
        ctrls.append(task.data.ctrl[0])
    expected = reference(model, task.low_level(), initial_state, np.full((1, 7, 1), 0.3))
    np.testing.assert_allclose(system.plant_state(), expected[0, -1, 1:5], rtol=1e-10, atol=1e-12)
    assert len(set(np.round(ctrls[:5], 12))) == 5  # five steps of one tick, five actions


@pytest.mark.parametrize(
    ("metadata", "order", "message"),
    [
        (
            {"name": "no_span"},
            None,
            "gives chunks of 4 actions (not horizon 1) but no chunk_horizon",
        ),
        (
            {"name": "two", "horizon": "0.3"},
            "quintic",
            "chunk_spline_order must be one of ['zero', 'linear', 'cubic']",
        ),
    ],
)
def test_a_chunk_without_a_known_layout_is_refused_in_one_line(metadata, order, message):
    with pytest.raises(PolicyError) as caught:
        LowLevel(
            LinearChunk(metadata=metadata), command_range=[[-1.0, 1.0]], chunk_spline_order=order
        )
    assert message in str(caught.value) and "\n" not in str(caught.value)
