"""`ControllerConfig.iterations_per_second`: a slower planning rate runs more optimizer iterations a
cycle, so it searches as much per second of control as a faster one; 20 by default (nothing changes
at 20 Hz and faster), checked like every field, and held to a deadline where the caller gives one
(the app: the control period)."""

import time

import numpy as np
import pytest

import judo
from judo.core.configuration.config import with_updates
from judo.core.configuration.controller_config import (
    MAX_OPT_ITERS,
    ControllerConfig,
    cycle_iterations,
)
from judo.core.configuration.registry import make_task
from judo.core.errors import ConfigError
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig


def test_the_iterations_of_a_cycle_follow_the_rate():
    # the default 20 per second at the default 20 Hz
    assert ControllerConfig().iterations_per_cycle == 1
    assert ControllerConfig(control_freq=5.0).iterations_per_cycle == 4
    assert ControllerConfig(control_freq=50.0, max_opt_iters=2).iterations_per_cycle == 2
    # 0: off
    assert ControllerConfig(control_freq=5.0, iterations_per_second=0.0).iterations_per_cycle == 1
    assert cycle_iterations(1, 20.0, 20.0) == 1
    assert cycle_iterations(1, 20.0, 5.0) == 4
    assert cycle_iterations(1, 20.0, 3.0) == 7  # at least: 6.67 rounds up
    assert cycle_iterations(1, 0.3, 0.1) == 3  # no float fuzz: 0.3 / 0.1 is 2.9999999999999996
    assert cycle_iterations(5, 20.0, 20.0) == 5  # never fewer than max_opt_iters
    config = ControllerConfig(control_freq=5.0, iterations_per_second=20.0)
    assert config.iterations_per_cycle == 4


def test_a_rate_that_would_need_too_many_iterations_runs_the_most_a_cycle_may():
    # the default 20 per second would ask for 200
    slowest = with_updates(ControllerConfig(), {"control_freq": 0.1})
    assert slowest.iterations_per_cycle == MAX_OPT_ITERS
    assert (
        with_updates(ControllerConfig(), {"iterations_per_second": 1e4}).iterations_per_cycle
        == MAX_OPT_ITERS
    )
    with pytest.raises(ConfigError, match="iterations_per_second"):
        with_updates(ControllerConfig(), {"iterations_per_second": -1.0})


class CountingSampling(PredictiveSampling):
    """Predictive sampling that counts its iterations (one `update_nominal_knots` per iteration)."""

    iterations = 0

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        self.iterations += 1
        return super().update_nominal_knots(sampled_knots, rewards)


@pytest.mark.parametrize(("control_freq", "expected"), [(20.0, 1), (5.0, 4)])
def test_a_controller_runs_the_cycles_iterations(control_freq, expected):
    task = make_task("cartpole")
    config = ControllerConfig(horizon=0.2, control_freq=control_freq, iterations_per_second=20.0)
    optimizer = CountingSampling(PredictiveSamplingConfig(num_rollouts=8), task.nu)
    with judo.Controller(config, task, optimizer, num_workers=1) as controller:
        state = np.concatenate([task.data.qpos, task.data.qvel])
        controller.update_action(state, 0.0)
        assert optimizer.iterations == expected


def test_a_deadline_ends_the_extra_iterations_but_never_the_required_ones():
    task = make_task("cartpole")
    # 4 a cycle, 2 of them required
    config = ControllerConfig(horizon=0.2, control_freq=5.0, max_opt_iters=2)
    optimizer = CountingSampling(PredictiveSamplingConfig(num_rollouts=8), task.nu)
    with judo.Controller(config, task, optimizer, num_workers=1) as controller:
        state = np.concatenate([task.data.qpos, task.data.qvel])
        # already past: the required 2
        controller.update_action(state, 0.0, deadline=time.perf_counter() - 1.0)
        assert optimizer.iterations == controller.iterations_run == 2
        controller.update_action(state, 0.1, deadline=time.perf_counter() + 60.0)  # room for all 4
        assert controller.iterations_run == 4 and optimizer.iterations == 6
        # no deadline (evaluate, in sim time): all 4, whatever they take
        controller.update_action(state, 0.2)
        assert controller.iterations_run == 4 and optimizer.iterations == 10
