"""The one closed-loop step: recorders see every plan and step, the latency model, the warm start
from the plant's state, and the deprecated warm start without a state."""

import numpy as np
import pytest
from slider_task import SLIDER_XML, HoldConfig, hold_base

import judo
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.controller import Controller
from judo.core.task import Task
from judo.loop.closed_loop import ClosedLoop
from judo.loop.records import PlanRecord, StepRecord
from judo.loop.system import MujocoSystem
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig


@pytest.fixture
def hold_task_cls(tmp_path):
    """A block on a rail with a position actuator; the reward wants the block at 0.5."""

    class Hold(hold_base(tmp_path)):
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
    optimizer = PredictiveSampling(
        PredictiveSamplingConfig(num_rollouts=8, num_nodes=2, sigma=0.3), nu=1
    )
    optimizer.rng = np.random.default_rng(seed)
    return Controller(
        ControllerConfig(horizon=0.1, control_freq=20.0), task_cls(), optimizer, num_workers=1
    )


def test_recorders_see_every_plan_and_every_step_in_order(hold_task_cls):
    recorder = ListRecorder()
    with hold_controller(hold_task_cls) as controller:
        plant = MujocoSystem.from_task(controller.task, seed=0)
        loop = ClosedLoop(controller, plant, recorders=[recorder])
        start = loop.restart()
        for _ in range(25):
            loop.step()
    # 20 Hz of sim time
    assert [p.time for p in recorder.plans] == pytest.approx([0.0, 0.05, 0.1, 0.15, 0.2])
    assert len(recorder.steps) == 25 and len(loop.update_ms) == 5
    assert [s.time for s in recorder.steps] == pytest.approx(start.time + 0.01 * np.arange(1, 26))
    step = recorder.steps[-1]
    assert step.state.shape == (2,) and step.sensors.shape == (1,) and step.action.shape == (1,)
    # the plant's own jointpos sensor: mj_step computes sensordata before it integrates, as evaluate
    # logged it
    assert step.sensors[0] == recorder.steps[-2].state[0]
    assert recorder.plans[0].knots.shape == (2, 1)
    assert (
        np.isfinite(recorder.plans[0].best_reward)
        and recorder.plans[0].best_reward >= recorder.plans[0].mean_reward
    )


def test_with_latency_the_warm_start_from_the_plants_state_holds_until_the_first_plan(
    hold_task_cls,
):
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
        # not yet: the warm start
        assert loop.serve(reading.time + 0.04) == pytest.approx(reading.state[:1])
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
    with pytest.warns(
        DeprecationWarning,
        match=r"OldStyle.optimizer_warm_start\(\) "
        r"without arguments is deprecated",
    ):
        controller = Controller(ControllerConfig(horizon=0.1), OldStyle(), optimizer, num_workers=1)
    with controller:
        assert controller.action(0.0) == pytest.approx([0.25])
        controller.update_action(np.zeros(2), 0.0)
        assert controller.nominal_knots is not None


def test_a_loop_that_keeps_few_updates_holds_the_latest_and_no_more_than_twice_as_many(
    hold_task_cls,
):
    """The app's loop runs for days: with `keep_updates` its update times stay bounded (a list of
    every update's grew about 80 kB a minute at 20 Hz over the wire), and the latest are the ones
    kept."""
    with hold_controller(hold_task_cls) as controller:
        kept = ClosedLoop(
            controller, MujocoSystem.from_task(controller.task, seed=0), keep_updates=3
        )
        every = ClosedLoop(controller, MujocoSystem.from_task(controller.task, seed=0))
        sizes = []
        for loop in (kept, every):
            loop.restart()
            for _ in range(100):  # 20 updates
                loop.step()
                if loop is kept:
                    sizes.append(len(kept.update_ms))
    assert len(every.update_ms) == len(every.latency_s) == 20
    assert max(sizes) == 6 and 3 <= len(kept.update_ms) == len(kept.latency_s) <= 6
    # latency 0: every update's delay is 0
    assert kept.latency_s == every.latency_s[-len(kept.latency_s) :]
    from judo.runtime.gui.controls import INFERENCE_WINDOW
    from judo.runtime.session import KEPT_UPDATES, build_session

    # the app's loop keeps as many
    session = build_session("cartpole", "ps", 0, seed=0, num_workers=1)
    try:
        assert session.closed_loop.keep_updates == KEPT_UPDATES >= INFERENCE_WINDOW
    finally:
        session.controller.close()


def test_the_public_loop_runs_a_registered_task():
    with judo.make_controller("cartpole", "ps", seed=0) as controller:
        loop = judo.ClosedLoop(controller, judo.MujocoSystem.from_task(controller.task, seed=0))
        loop.restart()
        for _ in range(10):
            loop.step()
    assert loop.reading is not None and loop.reading.time == pytest.approx(10 * controller.task.dt)
    assert loop.failed_updates == 0 and len(loop.update_ms) >= 1


def faulty_hold_task(hold_task_cls, fault_after: float, fault: str):
    """The hold task whose reward misbehaves once the rollouts start after `fault_after` s of plant
    time."""

    class Faulty(hold_task_cls):
        clock = staticmethod(lambda: 0.0)  # the test points it at the loop's clock

        def reward(self, states, sensors, controls, config, system_metadata=None):
            if self.clock() >= fault_after:
                if fault == "nan":
                    return np.full(len(states), np.nan)
                raise RuntimeError("the reward's model server is down")
            return super().reward(states, sensors, controls, config, system_metadata)

    return Faulty


@pytest.mark.parametrize("fault", ["nan", "raise"])
def test_the_watchdog_serves_the_safe_action_once_the_plan_is_too_old_and_resumes(
    hold_task_cls, fault
):
    """A reward that fails from t = 0.5 s: within max_plan_age + one period the plant gets
    safe_action (hold the block where it is); when the reward works again, plans are served
    again."""
    events = []
    task_cls = faulty_hold_task(hold_task_cls, 0.5, fault)
    optimizer = PredictiveSampling(
        PredictiveSamplingConfig(num_rollouts=8, num_nodes=2, sigma=0.3), nu=1
    )
    optimizer.rng = np.random.default_rng(0)
    config = ControllerConfig(horizon=0.1, control_freq=20.0, max_plan_age=0.2)
    with Controller(config, task_cls(), optimizer, num_workers=1) as controller:
        loop = ClosedLoop(
            controller, MujocoSystem.from_task(controller.task, seed=0), on_watchdog=events.append
        )
        controller.task.clock = lambda: loop.stepped_time
        loop.restart()
        # (time after the step, action served, position before the step, watchdog tripped)
        served = []
        for _ in range(150):
            before = loop.reading.state[0]
            try:
                record = loop.step()
            # the raising reward: the loop's caller (the app, evaluate) reports it
            except RuntimeError:
                record = loop.advance()
            served.append(
                (record.time, record.action[0], before, loop.watchdog.tripped is not None)
            )
            if record.time >= 1.2:
                controller.task.clock = lambda: -1.0  # the fault clears
    tripped = [row for row in served if row[3]]
    # the last good plan was from t <= 0.5; the watchdog trips within 0.2 + 0.05 s after it
    assert loop.watchdog.trips == 1 and events[0] is not None and events[-1] is None
    assert "plan in force is" in events[0]
    first_time, first_action, position, _ = tripped[0]
    assert 0.5 < first_time <= 0.5 + 0.2 + 0.05 + 0.011
    # safe_action: the position servo holds where the block is
    assert first_action == pytest.approx(position)
    assert all(row[1] == pytest.approx(row[2]) for row in tripped)
    assert not served[-1][3]
    assert loop.watchdog.tripped is None  # serving plans again at the end


def test_a_frozen_reading_trips_the_watchdog_and_a_reading_running_backwards_is_refused(
    hold_task_cls,
):
    from judo.core.errors import ReadingTimeError

    events = []
    with hold_controller(hold_task_cls) as controller:
        plant = MujocoSystem.from_task(controller.task, seed=0)
        loop = ClosedLoop(controller, plant, on_watchdog=events.append)
        controller.config.max_plan_age = 0.2
        loop.restart()
        for _ in range(20):
            loop.step()
        frozen = plant.read_state()
        plant.read_state = lambda: frozen  # the sensor stream freezes: the same reading forever
        for _ in range(40):
            loop.step()
        assert events and "has not advanced" in events[0]
        safe = loop.safe_action()
        assert loop.serve(loop.reading.time) == pytest.approx(safe)
        # hold the position actuator where the block was
        assert safe == pytest.approx(frozen.state[:1])
        plant.read_state = lambda: judo.SystemState(frozen.state, frozen.time - 1.0)
        with pytest.raises(ReadingTimeError, match="went backwards"):
            loop.read()


def test_max_plan_age_zero_turns_the_watchdog_off_and_halt_applies_the_safe_action(hold_task_cls):
    with hold_controller(hold_task_cls) as controller:
        plant = MujocoSystem.from_task(controller.task, seed=0)
        controller.config.max_plan_age = 0.0
        loop = ClosedLoop(controller, plant)
        reading = loop.restart()
        loop.plan(reading)
        loop.stepped_time += 100.0  # a very old plan
        assert loop.watchdog.verdict(loop.clock(), 0.0, 0.0, 20.0) is None
        assert loop.serve(reading.time) == pytest.approx(controller.action(reading.time))
        loop.halt()
        assert plant.task.data.ctrl[0] == pytest.approx(reading.state[0])


def test_an_estimator_plans_from_late_noisy_encoders_and_the_records_hold_truth_measurement_and_estimate():  # noqa: E501
    from judo.loop.sensing import SensedSystem

    recorder = ListRecorder()
    with judo.make_controller("pendulum", "mppi", seed=0) as controller:
        plant = MujocoSystem.from_task(controller.task, seed=0)
        sensed = SensedSystem(
            plant, noise=0.005, delay=0.01, rate=100.0, rng=np.random.default_rng(0)
        )
        ekf = judo.make_estimator("ekf", controller.task, task_name="pendulum")
        loop = ClosedLoop(controller, sensed, recorders=[recorder], estimator=ekf)
        first = loop.restart()
        # planned from the estimate
        assert loop.raw_reading.state is None and first.state.shape == (2,)
        for _ in range(100):
            loop.step()
    step = recorder.steps[-1]
    assert step.state == pytest.approx(plant.plant_state())  # the true state, for logs and metrics
    assert step.measured.shape == (1,) and step.estimate.shape == (2,)
    assert abs(step.estimate[0] - step.state[0]) < 0.05  # the estimate tracks the true angle
    assert abs(step.measured[0] - step.state[0]) > 0  # the encoder is noisy and late
    # as of the plant's now, not the late reading's
    assert loop.reading.time == pytest.approx(plant.task.data.time)
    # fed every served action
    assert loop.estimation.controls.at(loop.reading.time) == pytest.approx(step.action)
