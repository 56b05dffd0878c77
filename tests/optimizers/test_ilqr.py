"""ilqr: iLQR on the planning model's derivatives and the reward's expansion, with a parallel line
search."""

import numpy as np
import pytest

import judo
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.errors import ConfigError, JudoError
from judo.optimizers.ilqr import ILQR, ILQRConfig


def particle_plans(seed: int, updates: int) -> tuple[list[float], np.ndarray]:
    """The reward of the warm start (zero force: a poor start) from one particle state far from its
    goal, then of the nominal after each of `updates` updates from that state, and the final
    knots."""
    config = ControllerConfig(horizon=1.0, spline_order="cubic", max_num_traces=0)
    with judo.make_controller(
        "particle", "ilqr", controller_config=config, num_workers=2, seed=seed
    ) as controller:
        state = np.array([-0.3, 0.3, 0.0, 0.0])
        metadata = {"mocap_pos": np.array([[0.3, -0.2, 0.0]])}
        controller.update_action(state, 0.0, metadata)
        # the warm start's, the best step's
        rewards = [float(controller.rewards[0]), float(controller.rewards.max())]
        for _ in range(updates - 1):
            controller.update_action(state, 0.0, metadata)
            rewards.append(float(controller.rewards.max()))
        assert controller.nominal_knots is not None
        return rewards, controller.nominal_knots.copy()


def test_ilqr_lowers_the_cost_of_a_smooth_task_from_a_poor_start_and_is_deterministic_with_its_seed() -> (  # noqa: E501
    None
):
    rewards, knots = particle_plans(seed=3, updates=6)
    # the line search keeps the nominal when no step improves it
    assert np.all(np.diff(rewards) >= 0)
    # the cost falls by 40% or more
    assert rewards[-1] > rewards[0] + 0.4 * abs(rewards[0]), rewards
    again, same_knots = particle_plans(seed=3, updates=6)
    assert again == rewards
    np.testing.assert_array_equal(same_knots, knots)


def test_ilqr_is_registered_and_refuses_to_plan_outside_a_controller() -> None:
    assert "ilqr" in judo.get_registered_optimizers()
    optimizer = ILQR(ILQRConfig(), nu=2)
    with pytest.raises(JudoError, match="ilqr plans only inside a Controller"):
        optimizer.sample_control_knots(np.zeros((10, 2)))
    with pytest.raises(ConfigError, match="ilqr needs num_rollouts >= 2"):
        ILQRConfig(num_rollouts=1).validate()
