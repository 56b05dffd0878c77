"""ParallelReward: a large batch scored in blocks on threads gives exactly what one call gives."""

import threading

import numpy as np
import pytest

import judo
from judo.core.errors import JudoError
from judo.core.rollouts.parallel_reward import MIN_BLOCK_ROWS, ParallelReward


class CountingReward:
    """The tiny upright task's reward, recording each call's rows and thread."""

    def __init__(self, task):
        self.task, self.calls = task, []
        self.lock = threading.Lock()

    def __call__(self, states, sensors, controls, config, metadata=None):
        with self.lock:
            self.calls.append((states.shape[0], threading.current_thread().name))
        return self.task.reward(states, sensors, controls, config, metadata)


def batch(rows, rng):
    return (
        rng.normal(size=(rows, 7, 4)),
        rng.normal(size=(rows, 7, 4)),
        rng.normal(size=(rows, 7, 1)),
    )


def test_blocks_on_threads_equal_one_call_bit_for_bit(upright_task):
    rng = np.random.default_rng(0)
    states, sensors, controls = batch(1000, rng)
    reward = CountingReward(upright_task)
    split = ParallelReward(4)
    try:
        got = split(reward, states, sensors, controls, upright_task.config, None)
    finally:
        split.close()
    expected = upright_task.reward(states, sensors, controls, upright_task.config)
    np.testing.assert_array_equal(got, expected)
    rows = sorted(r for r, _ in reward.calls)
    assert len(rows) == 1000 // MIN_BLOCK_ROWS == 3 and sum(rows) == 1000  # 3 blocks of >= 256 rows
    assert all(name.startswith("judo-reward") for _, name in reward.calls)


def test_small_batches_and_one_thread_are_one_plain_call(upright_task):
    rng = np.random.default_rng(1)
    for threads, rows in ((8, 2 * MIN_BLOCK_ROWS - 1), (1, 4096)):
        reward = CountingReward(upright_task)
        ParallelReward(threads)(reward, *batch(rows, rng), upright_task.config, None)
        assert reward.calls == [(rows, threading.current_thread().name)]


def test_a_block_of_the_wrong_shape_is_named():
    def bad(states, sensors, controls, config, metadata):
        return np.zeros(states.shape[0] + 1)

    rng = np.random.default_rng(2)
    with pytest.raises(
        JudoError,
        match=r"reward returned shape \(257,\) "
        r"for rows 0:256, expected \(256,\)",
    ):
        ParallelReward(2)(bad, *batch(512, rng), None, None)


def test_a_controller_on_a_backend_that_asks_for_reward_threads_plans_exactly_as_without(
    upright_task,
):
    from judo.optimizers.mppi import MPPI, MPPIConfig

    def plan(reward_threads):
        optimizer = MPPI(MPPIConfig(num_rollouts=600), upright_task.nu)
        optimizer.rng = np.random.default_rng(0)
        controller = judo.Controller(
            judo.ControllerConfig(horizon=0.2), upright_task, optimizer, num_workers=1
        )
        controller.backend.reward_threads = reward_threads  # as the warp backend sets it
        controller._score = ParallelReward(reward_threads)
        with controller:
            controller.update_action(np.array([0.0, 0.5, 0.0, 0.0]), 0.0)
            return controller.rewards.copy(), controller.nominal_knots.copy()

    (rewards_1, knots_1), (rewards_4, knots_4) = plan(1), plan(4)
    np.testing.assert_array_equal(rewards_4, rewards_1)
    np.testing.assert_array_equal(knots_4, knots_1)
