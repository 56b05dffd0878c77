"""`with` closes what it opened: a rollout backend's threads, and a Controller's backend, also on an
error."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.model import STATE_SPEC
from judo.core.rollouts.backend import RolloutBackend
from judo.core.rollouts.rollout import RolloutPool


def zero_state(model: mujoco.MjModel) -> np.ndarray:
    return np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))


def assert_pool_closed(pool: RolloutPool) -> None:
    """The pool's worker threads have ended and it takes no more work."""
    assert pool._executor._threads and not any(
        thread.is_alive() for thread in pool._executor._threads
    )
    with pytest.raises(RuntimeError, match="cannot schedule new work after shutdown"):
        pool.rollout(zero_state(pool.model), np.zeros((4, 3, pool.model.nu)))


def test_with_a_rollout_pool_stops_its_threads(tiny_model_path):
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    with RolloutPool(model, num_workers=2) as pool:
        assert isinstance(pool, RolloutPool)
        states, _ = pool.rollout(zero_state(model), np.ones((4, 3, model.nu)))
        assert states.shape == (4, 3, zero_state(model).size)
        assert sum(thread.is_alive() for thread in pool._executor._threads) == 2
    assert_pool_closed(pool)


def test_an_error_inside_the_with_still_closes_the_pool_and_is_raised(tiny_model_path):
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    with (
        pytest.raises(ValueError, match="raised inside"),
        RolloutPool(model, num_workers=2) as pool,
    ):
        pool.rollout(zero_state(model), np.ones((4, 3, model.nu)))
        raise ValueError("raised inside")
    assert_pool_closed(pool)


def test_with_make_controller_closes_the_controller_and_its_backend():
    with judo.make_controller("cartpole", "mppi", num_workers=2, seed=0) as controller:
        assert isinstance(controller, judo.Controller)
        controller.update_action(np.array([0.0, 1.0, 0.0, 0.0]), 0.0)
        assert controller.rewards.shape == (controller.optimizer.num_rollouts,)
    assert isinstance(controller.backend, RolloutPool)
    assert_pool_closed(controller.backend)


def test_the_backend_is_an_object_and_its_name_is_read_only():
    with judo.make_controller("cartpole", "ps", num_workers=1) as controller:
        assert isinstance(controller.backend, RolloutBackend) and controller.backend_name == "cpu"
        with pytest.raises(AttributeError):
            controller.backend_name = "warp"  # type: ignore[misc]
        assert controller.backend_name == "cpu"
