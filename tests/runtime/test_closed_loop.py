"""The one closed-loop step: recorders see every plan and step, the latency model, the warm start from the
plant's state, and the deprecated warm start without a state."""

from dataclasses import dataclass

import numpy as np
import pytest

import judo
from judo.core.controller import Controller, ControllerConfig
from judo.core.task import Task, TaskConfig
from judo.optimizers import PredictiveSampling, PredictiveSamplingConfig
from judo.runtime.closed_loop import ClosedLoop
from judo.runtime.records import PlanRecord, StepRecord
from judo.runtime.system import MujocoSystem

SLIDER_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="block">
      <joint name="x" type="slide" axis="1 0 0" damping="1"/>
      <geom type="box" size="0.1 0.1 0.1" mass="1"/>
    </body>
  </worldbody>
  <actuator><position joint="x" kp="10" ctrlrange="-2 2" ctrllimited="true"/></actuator>
  <sensor><jointpos name="x_pos" joint="x"/></sensor>
</mujoco>
"""


@dataclass
class HoldConfig(TaskConfig):
    """No settings."""


@pytest.fixture
def hold_task_cls(tmp_path):
    """A block on a rail with a position actuator; the reward wants the block at 0.5."""
    path = tmp_path / "slider.xml"
    path.write_text(SLIDER_XML)

    class Hold(Task[HoldConfig]):
        def __init__(self):
            super().__init__(path)

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return -np.abs(states[..., 0] - 0.5).sum(-1)

        def reset(self):
            self.data.qpos[:] = 0.3 + 0.1 * self.rng.uniform()
            self.data.qvel[:] = 0.0

        def optimizer_warm_start(self, state):
            return state[:1].copy()  # hold the block where it is

    return Hold


class ListRecorder:
    def __init__(self):
        self.plans: list[PlanRecord] = []
        self.steps: list[StepRecord] = []

    def on_plan(self, record):
        self.plans.append(record)

    def on_step(self, record):
        self.steps.append(record)


def hold_controller(task_cls, seed=0):
    optimizer = PredictiveSampling(PredictiveSamplingConfig(num_rollouts=8, num_nodes=2, sigma=0.3), nu=1)
    optimizer.rng = np.random.default_rng(seed)
    return Controller(ControllerConfig(horizon=0.1, control_freq=20.0), task_cls(), optimizer, num_workers=1)


def test_recorders_see_every_plan_and_every_step_in_order(hold_task_cls):
    recorder = ListRecorder()
    with hold_controller(hold_task_cls) as controller:
        plant = MujocoSystem.from_task(controller.task, seed=0)
        loop = ClosedLoop(controller, plant, recorders=[recorder])
        start = loop.restart()
        for _ in range(25):
            loop.step()
    assert [p.time for p in recorder.plans] == pytest.approx([0.0, 0.05, 0.1, 0.15, 0.2])  # 20 Hz of sim time
    assert len(recorder.steps) == 25 and len(loop.update_ms) == 5
    assert [s.time for s in recorder.steps] == pytest.approx(start.time + 0.01 * np.arange(1, 26))
    step = recorder.steps[-1]
    assert step.state.shape == (2,) and step.sensors.shape == (1,) and step.action.shape == (1,)
    # the plant's own jointpos sensor: mj_step computes sensordata before it integrates, as evaluate logged it
    assert step.sensors[0] == recorder.steps[-2].state[0]
    assert recorder.plans[0].knots.shape == (2, 1)
    assert np.isfinite(recorder.plans[0].best_reward) and recorder.plans[0].best_reward >= recorder.plans[0].mean_reward


def test_with_latency_the_warm_start_from_the_plants_state_holds_until_the_first_plan(hold_task_cls):
    recorder = ListRecorder()
    with hold_controller(hold_task_cls) as controller:
        plant = MujocoSystem.from_task(controller.task, seed=1)
        loop = ClosedLoop(controller, plant, latency=0.03, recorders=[recorder])
        start = loop.restart()
        for _ in range(6):
            loop.step()
    actions = np.array([s.action[0] for s in recorder.steps])
    assert actions[:3] == pytest.approx([start.state[0]] * 3)  # the block's start position, held
    assert recorder.plans[0].takes_effect == pytest.approx(0.03)
    assert not np.allclose(actions[3:], start.state[0])  # the first plan, from t = 0.03


def test_serve_takes_the_latest_plan_whose_time_has_come(hold_task_cls):
    with hold_controller(hold_task_cls) as controller:
        loop = ClosedLoop(controller, MujocoSystem.from_task(controller.task, seed=0), latency=0.05)
        reading = loop.restart()
        plan = loop.plan(reading)
        assert plan is not None
        assert loop.serve(reading.time + 0.04) == pytest.approx(reading.state[:1])  # not yet: the warm start
        assert loop.serve(reading.time + 0.05) == pytest.approx(plan(reading.time + 0.05))


def test_a_warm_start_without_the_state_still_works_with_a_deprecation_warning(tmp_path):
    path = tmp_path / "slider.xml"
    path.write_text(SLIDER_XML)

    class OldStyle(Task[HoldConfig]):
        def __init__(self):
            super().__init__(path)

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return -np.abs(states[..., 0]).sum(-1)

        def optimizer_warm_start(self):
            return np.array([0.25])

    optimizer = PredictiveSampling(PredictiveSamplingConfig(num_rollouts=4, num_nodes=2), nu=1)
    with pytest.warns(DeprecationWarning, match=r"OldStyle.optimizer_warm_start\(\) without arguments is deprecated"):
        controller = Controller(ControllerConfig(horizon=0.1), OldStyle(), optimizer, num_workers=1)
    with controller:
        assert controller.action(0.0) == pytest.approx([0.25])
        controller.update_action(np.zeros(2), 0.0)
        assert controller.nominal_knots is not None


def test_the_public_loop_runs_a_registered_task():
    with judo.make_controller("cartpole", "ps", seed=0) as controller:
        loop = judo.ClosedLoop(controller, judo.MujocoSystem.from_task(controller.task, seed=0))
        loop.restart()
        for _ in range(10):
            loop.step()
    assert loop.reading is not None and loop.reading.time == pytest.approx(10 * controller.task.dt)
    assert loop.failed_updates == 0 and len(loop.update_ms) >= 1
