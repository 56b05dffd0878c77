"""`model_at` (a state into a scratch MjData) and `PolicyStepper` (a batch stepped with a policy
between physics ticks), each against a plain-Python reference on a tiny inline model, bit for
bit."""

import mujoco
import mujoco.rollout
import numpy as np
import pytest

from judo.core.model import STATE_SPEC
from judo.core.reading import mocap_metadata, mocap_vector, model_at
from judo.core.rollouts.rollout import RolloutPool
from judo.core.rollouts.stepper import PolicyStepper

XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <geom type="plane" size="2 2 .1"/>
    <body name="cart" pos="0 0 .1">
      <joint name="slider" type="slide" axis="1 0 0"/>
      <geom type="box" size=".2 .1 .1" mass="1"/>
      <body name="pole">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.6" size=".04" mass=".1"/>
      </body>
    </body>
    <body name="goal" mocap="true" pos="0 0 1"><site name="goal"/></body>
  </worldbody>
  <actuator>
    <motor name="push" joint="slider" gear="10" ctrlrange="-1 1" ctrllimited="true"/>
    <motor joint="hinge" ctrlrange="-1 1" ctrllimited="true"/>
  </actuator>
  <sensor>
    <framepos objtype="site" objname="goal"/>
    <jointpos joint="hinge"/>
    <actuatorfrc actuator="push"/>
    <clock/>
  </sensor>
</mujoco>
"""
GOAL = {"mocap_pos": np.array([[0.3, -0.2, 0.8]]), "mocap_quat": np.array([[0.0, 1.0, 0.0, 0.0]])}


@pytest.fixture(scope="module")
def model():
    return mujoco.MjModel.from_xml_string(XML)


def test_model_at_puts_a_reading_and_its_mocap_into_the_data_and_runs_forward(model):
    state = np.array([0.1, 0.4, -0.2, 0.3])  # [qpos, qvel]
    data = mujoco.MjData(model)
    data.ctrl[:] = [0.5, 0.0]  # left as it is: the actuator force sensor reads it
    assert model_at(model, data, state, 1.25, GOAL) is data
    expected = mujoco.MjData(model)
    expected.time, expected.qpos[:], expected.qvel[:], expected.ctrl[:] = (
        1.25,
        state[:2],
        state[2:],
        [0.5, 0.0],
    )
    expected.mocap_pos[:], expected.mocap_quat[:] = GOAL["mocap_pos"], GOAL["mocap_quat"]
    mujoco.mj_forward(model, expected)
    np.testing.assert_array_equal(data.sensordata, expected.sensordata)
    np.testing.assert_array_equal(data.sensordata[:3], GOAL["mocap_pos"][0])
    # the ctrl's force; the clock reads the time
    assert data.sensordata[4] == 0.5 and data.sensordata[5] == 1.25
    np.testing.assert_array_equal(
        mocap_vector(data), np.concatenate([[0.3, -0.2, 0.8], [0.0, 1.0, 0.0, 0.0]])
    )


def test_model_at_takes_a_full_physics_state_and_keeps_what_it_is_not_given(model):
    data = mujoco.MjData(model)
    model_at(model, data, np.array([0.1, 0.4, -0.2, 0.3]), 0.5, GOAL)
    full = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, full, STATE_SPEC)
    other = mujoco.MjData(model)
    model_at(model, other, full, metadata=mocap_metadata(model, mocap_vector(data)))  # its own time
    np.testing.assert_array_equal(other.sensordata, data.sensordata)
    before = other.sensordata.copy()
    # no time, no mocap poses, no forward
    model_at(model, other, np.zeros(4), None, {"other": 1}, forward=False)
    assert other.time == 0.5 and other.qpos[1] == 0.0
    np.testing.assert_array_equal(other.mocap_pos, GOAL["mocap_pos"])
    np.testing.assert_array_equal(other.sensordata, before)


def linear(weight, observations):
    """(B, 2) tanh(W obs), each row computed alone (so a batch of one gives the bits of a row of a
    batch of N)."""
    out = np.zeros((len(observations), len(weight)))
    for j in range(weight.shape[1]):
        out += observations[:, j : j + 1] * weight[:, j]
    return np.tanh(out)


def reference(model, initial, weight, commands, every, mocap):
    """One row at a time with mj_step: every k steps tanh(W [command, qpos, qvel]) held as the ctrl
    (a cold solver start at each tick, as MuJoCo's rollout starts each call)."""
    data = mujoco.MjData(model)
    num_rows, num_steps = len(commands), commands.shape[1]
    states = np.zeros((num_rows, num_steps, len(initial)))
    for i in range(num_rows):
        mujoco.mj_setState(model, data, initial, STATE_SPEC)
        data.mocap_pos[:], data.mocap_quat[:] = mocap[:3], mocap[3:]
        for t in range(num_steps):
            if t % every == 0:
                observation = np.concatenate([commands[i, t], data.qpos, data.qvel])
                data.ctrl[:] = linear(weight, observation[None])[0]
                data.qacc_warmstart[:] = 0.0
            mujoco.mj_step(model, data)
            mujoco.mj_getState(model, data, states[i, t], STATE_SPEC)
    return states


@pytest.mark.parametrize("workers", [1, 2])
def test_the_stepper_runs_block_by_block_as_a_plain_loop_bit_for_bit(model, workers):
    every, num_steps = 3, 8  # ticks at 0, 3, 6: the last one two steps
    weight = np.random.default_rng(0).normal(0.0, 0.5, (2, 5))
    commands = np.random.default_rng(1).uniform(-1, 1, (5, num_steps, 1))
    commands[3, 3] = np.nan  # row 3's policy gives NaN at its second tick
    initial = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    data = model_at(
        model, mujoco.MjData(model), np.array([0.1, 0.2, 0.0, -0.1]), 0.0, forward=False
    )
    mujoco.mj_getState(model, data, initial, STATE_SPEC)
    mocap = np.concatenate([GOAL["mocap_pos"][0], GOAL["mocap_quat"][0]])
    stepper = PolicyStepper(model, action_size=2, every=every, observation_size=5)
    states = np.zeros((5, num_steps, len(initial)))
    calls = []

    def observe(rows, start, current, previous):
        out = stepper.observations[rows]
        out[:, :1], out[:, 1:] = commands[rows, start], current[:, 1:5]
        return out

    def act(rows, observations):
        calls.append(len(observations))
        return linear(weight, observations)[:, None, :]

    def record(rows, start, stop):
        states[rows, start:stop] = stepper.states[stop - start][rows]

    with RolloutPool(model, workers) as pool:
        stepper.start(5, num_steps, initial, mocap)
        assert stepper.ticks == [(0, 3), (3, 6), (6, 8)]
        blocks = stepper.run_blocks(pool, observe, act, record)
    expected = reference(model, initial, weight, commands, every, mocap)
    finite = np.arange(5) != 3
    np.testing.assert_array_equal(states[finite], expected[finite])
    np.testing.assert_array_equal(stepper.current[finite], expected[finite, -1])
    assert stepper.finite.tolist() == finite.tolist()
    # one act per tick and block
    assert blocks == workers and len(calls) == 3 * workers and sum(calls) == 3 * 5
    np.testing.assert_array_equal(
        stepper.sensors[2][finite, -1, :3], np.broadcast_to(GOAL["mocap_pos"], (4, 3))
    )


def test_a_chunk_gives_each_step_its_action_and_the_last_one_is_the_previous(model):
    weights = np.array([[1.0, 0.0], [0.5, 0.5], [0.0, 1.0]])  # three steps from two knots, linearly
    stepper = PolicyStepper(
        model, 2, every=3, step_weights=lambda n: weights[:n], to_ctrl=lambda a: 2.0 * a
    )
    stepper.start(2, 3, np.zeros(stepper.nstate))
    chunk = np.array([[[0.1, 0.2], [0.3, 0.4]], [[-0.1, 0.0], [0.1, 0.2]]])  # (B, H, A)
    ctrl = stepper.act(slice(0, 2), chunk, 3)
    np.testing.assert_allclose(ctrl, 2.0 * np.einsum("sh,bha->bsa", weights, chunk))
    np.testing.assert_array_equal(stepper.previous, chunk[:, -1])
    assert (
        np.shares_memory(ctrl, stepper.inputs[3])
        and stepper.control_spec == mujoco.mjtState.mjSTATE_CTRL
    )
