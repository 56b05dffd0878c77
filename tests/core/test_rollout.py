"""The rollout pool equals a plain sequential mj_step loop, bit for bit, for any worker count."""

import time

import mujoco
import numpy as np
import pytest

from judo.core.errors import MissingExtraError, UnknownNameError, import_extra
from judo.core.model import STATE_SPEC
from judo.core.rollouts.factory import make_rollout_backend
from judo.core.rollouts.rollout import RolloutPool


def sequential_rollouts(model, initial_state, controls):
    """Reference: one MjData, mj_setState then mj_step per control, recording state and sensors."""
    data = mujoco.MjData(model)
    num_rollouts, num_steps, _ = controls.shape
    states = np.zeros((num_rollouts, num_steps, mujoco.mj_stateSize(model, STATE_SPEC)))
    sensors = np.zeros((num_rollouts, num_steps, model.nsensordata))
    for i in range(num_rollouts):
        mujoco.mj_setState(model, data, initial_state, STATE_SPEC)
        for t in range(num_steps):
            data.ctrl[:] = controls[i, t]
            mujoco.mj_step(model, data)
            mujoco.mj_getState(model, data, states[i, t], STATE_SPEC)
            sensors[i, t] = data.sensordata
    return states, sensors


@pytest.mark.parametrize("num_workers", [1, 2, 3])
def test_pool_matches_sequential_mj_step_bit_for_bit(tiny_model_path, num_workers):
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    data = mujoco.MjData(model)
    data.qpos[:] = [0.1, 2.5]
    data.qvel[:] = [0.3, -0.2]
    initial_state = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, initial_state, STATE_SPEC)
    controls = np.random.default_rng(0).uniform(-1, 1, (7, 40, model.nu))

    pool = RolloutPool(model, num_workers)
    states, sensors = pool.rollout(initial_state, controls)
    expected_states, expected_sensors = sequential_rollouts(model, initial_state, controls)
    pool.close()

    np.testing.assert_array_equal(states, expected_states)
    np.testing.assert_array_equal(sensors, expected_sensors)
    # different controls really gave different rollouts
    assert not np.allclose(states[0], states[1])


def test_pool_reallocates_when_the_batch_shape_changes(tiny_model_path):
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    pool = RolloutPool(model, 2)
    initial_state = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    first, _ = pool.rollout(initial_state, np.zeros((4, 10, 1)))
    second, _ = pool.rollout(initial_state, np.ones((6, 5, 1)))
    pool.close()
    assert first.shape == (4, 10, initial_state.size) and second.shape == (6, 5, initial_state.size)
    assert pool.num_workers == 2


def test_unknown_backend_name_lists_the_valid_ones(tiny_model_path):
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    with pytest.raises(
        UnknownNameError,
        match="unknown rollout backend 'gpu'; valid rollout backends are: cpu, warp",
    ):
        make_rollout_backend("gpu", model)


def test_missing_extra_names_the_extra_to_install():
    with pytest.raises(MissingExtraError) as caught:
        import_extra("judo_no_such_module", "the feature", "warp")
    assert str(caught.value) == (
        "the feature needs the optional extra judo-mpc[warp], which is not installed "
        "(no module 'judo_no_such_module'); install it with: pip install -e \".[warp]\" "
        "(from a checkout) or "
        'pip install "judo-mpc[warp]"'
    )


def test_each_block_runs_once_and_a_worker_s_error_is_raised_only_after_every_block_ended(
    tiny_model_path,
):
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    with RolloutPool(model, 3) as pool:
        assert [(rows.start, rows.stop) for rows in pool.blocks(7)] == [(0, 2), (2, 4), (4, 7)]
        assert len(pool.blocks(2)) == 2  # never an empty block
        ran: list[int] = []
        pool.for_each_block(7, ran.append)
        assert sorted(ran) == [0, 1, 2]

        ended: list[int] = []

        def fail_on_block_2(block: int) -> None:
            if block == 2:
                raise ValueError("block 2 failed")
            time.sleep(0.2)  # the caller's block 0 and block 1 outlast block 2's failure
            ended.append(block)

        with pytest.raises(ValueError, match="block 2 failed"):
            pool.for_each_block(7, fail_on_block_2)
        assert sorted(ended) == [0, 1]
