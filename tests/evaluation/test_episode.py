from dataclasses import dataclass

import numpy as np
import pytest

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.controller import Controller
from judo.core.errors import ConfigError
from judo.core.task import Task, TaskConfig
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig

SLIDER_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="block">
      <joint name="x" type="slide" axis="1 0 0" damping="1"/>
      <geom type="box" size="0.1 0.1 0.1" mass="1"/>
    </body>
  </worldbody>
  <actuator><motor joint="x" ctrlrange="-1 1" ctrllimited="true"/></actuator>
</mujoco>
"""


@dataclass
class PushConfig(TaskConfig):
    """No settings."""


@pytest.fixture
def push_task_cls(tmp_path):
    """A block on a rail whose reward is the total push, so every plan pushes at +1."""
    path = tmp_path / "slider.xml"
    path.write_text(SLIDER_XML)

    class Push(Task[PushConfig]):
        def __init__(self):
            super().__init__(path)

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return controls.sum(axis=(1, 2))

        def reset(self):
            self.data.qpos[:] = self.rng.uniform(-1, 1)
            self.data.qvel[:] = 0.0

    return Push


def push_controller(task_cls, seed=0, control_freq=20.0):
    optimizer = PredictiveSampling(
        PredictiveSamplingConfig(num_rollouts=8, num_nodes=2, sigma=0.5), nu=1
    )
    optimizer.rng = np.random.default_rng(seed)
    return Controller(
        ControllerConfig(horizon=0.1, control_freq=control_freq),
        task_cls(),
        optimizer,
        num_workers=1,
    )


def test_without_latency_the_first_plan_drives_the_first_step(push_task_cls):
    controller = push_controller(push_task_cls)
    result = run_episode(controller, MujocoSystem.from_task(controller.task, seed=0), duration=0.2)
    assert result.log.controls.shape == (20, 1)
    assert result.log.controls[0, 0] > 0.0
    assert len(result.update_ms) == 4  # every 0.05 s over 0.2 s
    assert np.all(result.latency_s == 0.0)


def test_a_fixed_latency_holds_the_previous_plan_until_the_new_one_takes_effect(push_task_cls):
    latency = 0.03  # three plant steps
    controller = push_controller(push_task_cls)
    result = run_episode(
        controller, MujocoSystem.from_task(controller.task, seed=0), duration=0.2, latency=latency
    )
    controls = result.log.controls[:, 0]
    assert np.all(controls[:3] == 0.0)  # the warm start, until the first plan arrives at t = 0.03
    assert np.all(controls[3:] > 0.0)
    # at t = 0.05 the second plan is computed, but the first one still drives steps 5-7
    first_plan = push_controller(push_task_cls)
    plan = first_plan.update_action(
        MujocoSystem.from_task(first_plan.task, seed=0).task.data.qpos.tolist() + [0.0], 0.0
    )
    assert controls[5:8] == pytest.approx(plan(0.01 * np.arange(5, 8))[:, 0])
    assert np.all(result.latency_s == latency)


def test_a_latency_longer_than_the_control_period_delays_the_next_plan(push_task_cls):
    controller = push_controller(push_task_cls)  # period 0.05 s
    result = run_episode(
        controller, MujocoSystem.from_task(controller.task, seed=0), duration=0.5, latency=0.12
    )
    assert len(result.update_ms) == 5  # plans start at 0, 0.12, 0.24, 0.36, 0.48


def test_measured_latency_is_the_update_wall_time(push_task_cls):
    controller = push_controller(push_task_cls)
    result = run_episode(
        controller,
        MujocoSystem.from_task(controller.task, seed=0),
        duration=0.2,
        latency="measured",
    )
    assert result.latency_s == pytest.approx(result.update_ms / 1e3)


def test_the_same_seed_gives_the_same_episode(push_task_cls):
    def episode(seed):
        controller = push_controller(push_task_cls, seed)
        return run_episode(
            controller, MujocoSystem.from_task(controller.task, seed), duration=0.3, latency=0.02
        )

    first, again, other = episode(3), episode(3), episode(4)
    assert np.array_equal(first.log.states, again.log.states)
    assert np.array_equal(first.log.controls, again.log.controls)
    assert not np.array_equal(first.log.states[0], other.log.states[0])  # a different random start


def test_rewards_and_mean_reward_score_each_step_alone(push_task_cls):
    controller = push_controller(push_task_cls)
    result = run_episode(controller, MujocoSystem.from_task(controller.task, seed=0), duration=0.2)
    assert result.rewards == pytest.approx(result.log.controls[:, 0])  # the push reward of one step
    assert result.metrics == {"mean_reward": pytest.approx(result.log.controls.mean())}


def test_bad_episode_arguments_are_refused(push_task_cls):
    controller = push_controller(push_task_cls)
    plant = MujocoSystem.from_task(controller.task, seed=0)
    with pytest.raises(ConfigError, match=r"^duration must be positive and finite, got 0.0$"):
        run_episode(controller, plant, duration=0.0)
    with pytest.raises(ConfigError, match=r"^latency must be at least 0 s and finite, got -0.1$"):
        run_episode(controller, plant, duration=1.0, latency=-0.1)
