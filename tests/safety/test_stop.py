"""The latched stop (judo.safety.stop): persisted until an explicit clear, served by the closed loop
as the safe action (or the System's own halt), through new plans, a reset, a switch and a restart of
the app."""

import json
import logging
import threading
import time

import numpy as np
import pytest

import judo
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.errors import ConfigError
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import MujocoSystem
from judo.runtime.app import App
from judo.safety.stop import STOP_FILE_ENV, StopLatch, default_stop_file, wire_request


def wait_until(condition, timeout: float = 60.0, what: str = "condition") -> None:
    """Poll `condition()` until it is true, or fail saying `what` did not happen (a loaded machine
    is slow)."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.01)


class Served:
    """A recorder of every action the closed loop served (thread-safe, in order)."""

    def __init__(self) -> None:
        self.actions: list[np.ndarray] = []
        self._lock = threading.Lock()

    def on_plan(self, record) -> None:
        pass

    def on_step(self, record) -> None:
        with self._lock:
            self.actions.append(np.array(record.action))

    def since(self, index: int) -> np.ndarray:
        """(k, nu) the actions served from step `index` on."""
        with self._lock:
            return np.array(self.actions[index:])

    def __len__(self) -> int:
        with self._lock:
            return len(self.actions)


def test_a_latch_is_persisted_until_it_is_cleared_and_a_repeat_changes_nothing(tmp_path):
    path = tmp_path / "state" / "stop.json"
    latch = StopLatch(path)
    assert not latch.latched and not path.exists() and latch.events == []
    assert latch.engage("the test") and latch.latched
    assert json.loads(path.read_text())["source"] == "the test"
    assert not latch.engage("a repeat")  # /judo/estop true ten times a second is one event
    assert [(event.source, event.engaged) for event in latch.events] == [("the test", True)]
    again = StopLatch(path)  # a restart
    assert again.latched
    assert again.latest is not None and again.latest.source == (
        f"the test (from the state file {path})"
    )
    assert "Clear stop" in again.start_line() and str(path) in again.start_line()
    assert again.clear("the operator") and not again.latched and not path.exists()
    assert not again.clear("a repeat")
    assert not StopLatch(path).latched
    latch.close(), again.close()


def test_a_state_file_that_cannot_be_read_still_latches(tmp_path):
    path = tmp_path / "stop.json"
    path.write_text("{not json")
    latch = StopLatch(path)
    assert latch.latched
    assert latch.latest is not None and "unreadable: JSONDecodeError" in latch.latest.source
    latch.close()


def test_a_state_file_that_cannot_be_written_is_refused_in_one_line(tmp_path):
    with pytest.raises(ConfigError) as refused:
        StopLatch(tmp_path)
    assert (
        str(refused.value)
        == f"the stop's state file (--stop-file, $JUDO_STOP_FILE) '{tmp_path}' is a folder; "
        "give a file path"
    )
    (tmp_path / "a_file").write_text("")
    with pytest.raises(ConfigError, match="is a file, so .* cannot be made"):
        App("cartpole", "ps", gui=False, stop_file=tmp_path / "a_file" / "stop.json")


def test_the_state_file_is_named_by_the_environment_else_the_user_state_dir(monkeypatch, tmp_path):
    monkeypatch.setenv(STOP_FILE_ENV, str(tmp_path / "robot.json"))
    assert default_stop_file() == tmp_path / "robot.json"
    monkeypatch.delenv(STOP_FILE_ENV)
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    assert default_stop_file() == tmp_path / "state" / "judo" / "stop.json"


def test_a_wire_request_latches_and_clears_every_open_latch(tmp_path):
    first, second, deaf = StopLatch(tmp_path / "a.json"), StopLatch(None), StopLatch(None)
    first.listen(), second.listen()
    try:
        assert wire_request(True, "/judo/estop") == 2
        assert not deaf.latched  # a latch that does not listen (an app not running) is not reached
        assert first.latched and second.latched and (tmp_path / "a.json").exists()
        assert wire_request(True, "/judo/estop") == 0  # already latched: no new event
        second.close()
        assert wire_request(False, "/judo/estop") == 1
        assert not first.latched and second.latched  # a closed latch is no longer reached
        assert [event.engaged for event in first.events] == [True, False]
    finally:
        first.close(), second.close()


class HaltingPlant(MujocoSystem):
    """A simulated plant with its own halt, counting halts and applied actions."""

    def __init__(self, task) -> None:
        super().__init__(task)
        self.halts = self.applies = 0

    def halt(self) -> bool:
        self.halts += 1
        return True

    def apply(self, action: np.ndarray) -> None:
        self.applies += 1
        super().apply(action)


def test_a_system_with_its_own_halt_is_halted_once_per_latch_and_applied_nothing_meanwhile():
    config = ControllerConfig(horizon=0.5, max_opt_iters=1)
    with judo.make_controller(
        "cartpole", "ps", controller_config=config, num_workers=1, seed=0
    ) as controller:
        plant = HaltingPlant.from_task(controller.task, seed=0)
        assert isinstance(plant, HaltingPlant)
        latch = StopLatch(None)
        loop = ClosedLoop(controller, plant, stop=latch)
        try:
            for _ in range(20):
                loop.step()
            assert (plant.halts, plant.applies) == (0, 20)
            latch.engage("the test")
            records = [loop.step() for _ in range(30)]
            assert (plant.halts, plant.applies) == (1, 20)  # halted once, then nothing applied
            assert all(
                np.array_equal(record.action, loop.safe_action())
                for record in records
                if record is not None
            )
            assert latch.latest is not None and latch.latest.effect_s is not None
            latch.clear("the test")
            for _ in range(5):
                loop.step()
            assert (plant.halts, plant.applies) == (1, 25)
            latch.engage("the test again")
            loop.step()
            assert plant.halts == 2
        finally:
            latch.close()


@pytest.fixture
def stop_file(tmp_path):
    return tmp_path / "stop.json"


def started_app(stop_file, served: Served, optimizer: str = "mppi") -> App:
    """A running headless cartpole App on `stop_file`, every served action recorded from its first
    step."""
    app = App("cartpole", optimizer, gui=False, seed=0, num_workers=1, stop_file=stop_file)
    app.session.closed_loop.recorders.append(served)
    app.start()
    return app


def test_the_app_serves_the_safe_action_from_a_latch_through_new_plans_a_reset_and_a_switch_until_cleared(  # noqa: E501
    stop_file,
):
    served = Served()
    app = started_app(stop_file, served)
    try:
        wait_until(
            lambda: app.stats.num_plans() >= 2 and np.any(served.since(0) != 0), what="plans served"
        )
        latch = app.stop_latch
        assert app.session.closed_loop.stop is latch
        latch.engage("the test")
        wait_until(
            lambda: latch.latest is not None and latch.latest.effect_s is not None,
            what="the stop's effect",
        )
        print(f"app.stop_latch.engage -> the safe action served: {latch.latest.effect_s:.3f} s")
        index, plans = len(served), app.stats.num_plans()
        # a new plan does not clear it
        wait_until(lambda: app.stats.num_plans() >= plans + 3, what="new plans")
        app.commands.reset_task()
        wait_until(lambda: app.resets_done >= 1, what="the reset")
        generation = app.session.generation
        app.commands.switch_optimizer("ps")
        wait_until(lambda: app.session.generation > generation, what="the switch")
        session = app.session
        assert session.closed_loop.stop is latch
        session.closed_loop.recorders.append(served)
        wait_until(lambda: app.stats.num_plans() >= plans + 6, what="plans of the new session")
        assert latch.latched and stop_file.exists()
        stopped = served.since(index)
        assert len(stopped) > 0 and np.all(stopped == 0.0), "cartpole's safe action is 0"
        index = len(served)
        latch.clear("the test")
        wait_until(
            lambda: np.any(served.since(index) != 0), what="the plan served again after the clear"
        )
        assert not stop_file.exists()
    finally:
        app.stop()
    summary = str(app.summary())
    assert (
        "latched by the test at" in summary
        and "in effect after" in summary
        and "cleared by the test" in summary
    )


def test_an_app_started_on_a_latched_state_file_serves_the_safe_action_from_its_first_step(
    stop_file, caplog
):
    StopLatch(stop_file).engage("an earlier run")
    served = Served()
    with caplog.at_level(logging.INFO, logger="judo.app"):
        app = started_app(stop_file, served)
        try:
            wait_until(lambda: app.stats.num_plans() >= 3 and len(served) > 10, what="plans")
        finally:
            app.stop()
    assert np.all(served.since(0) == 0.0)
    assert app.stop_latch.latched and stop_file.exists()
    told = [r.getMessage() for r in caplog.records if "the stop is latched" in r.getMessage()]
    assert told and "an earlier run (from the state file" in told[0] and "Clear stop" in told[0], (
        told
    )
    assert "still latched at exit" in str(app.summary())


def test_each_latch_and_clear_is_a_config_edit_in_a_recording(stop_file, tmp_path):
    h5py = pytest.importorskip("h5py")
    served = Served()
    app = started_app(stop_file, served)
    try:
        wait_until(lambda: len(served) > 5, what="steps")
        path = app.start_recording(tmp_path / "run.h5")
        count = len(served)
        app.stop_latch.engage("the test")
        app.stop_latch.clear("the test")
        wait_until(lambda: len(served) > count + 5, what="steps recorded")
        app.stop_recording()
    finally:
        app.stop()
    with h5py.File(path) as file:
        edits = json.loads(file["data"]["demo_0"].attrs["config_edits"])
    stops = [
        (edit["kind"], edit["source"], edit["engaged"]) for edit in edits if edit["kind"] == "stop"
    ]
    assert stops == [("stop", "the test", True), ("stop", "the test", False)]
    assert all(
        isinstance(edit["time"], float) and edit["wall_time"] > 0
        for edit in edits
        if edit["kind"] == "stop"
    )
