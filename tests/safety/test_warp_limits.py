"""Rollout feasibility on the MuJoCo Warp backend: the same screen on the host arrays it hands back
(warp's default device: the CPU device where there is no GPU)."""

import numpy as np
import pytest

from judo.core.configuration.registry import make_controller
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem
from judo.safety.config import SafetyConfig
from judo.safety.serve_filter import safety_guard

pytestmark = [pytest.mark.warp, pytest.mark.slow]


def test_warp_rollouts_that_cross_a_limit_never_win():
    pytest.importorskip("mujoco_warp")
    controller = make_controller("cartpole", "ps", seed=7, backend="warp")
    with controller:
        loop = ClosedLoop(
            controller,
            MujocoSystem.from_task(controller.task, seed=7),
            guard=safety_guard(controller, SafetyConfig(position=("slider=-0.3:0.3",))),
        )
        state = np.array([0.1, np.pi, 0.5, 0.0])  # as on the CPU pool: most samples cross the limit
        controller.update_action(state, 0.0)
        infeasible = controller.limits.last_infeasible
        assert infeasible.any() and not infeasible.all()
        assert np.all(controller.rewards[infeasible] == -np.inf)
        assert not infeasible[int(np.argmax(controller.rewards))]
        assert loop.guard is not None
