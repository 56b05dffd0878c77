"""The App is composed of parts that own their state: no runtime class inherits another's, every
attribute is written by the class that owns it, one control clock schedules plans, and recording and
the GUI are injected."""

import abc
import ast
import importlib
import inspect
import math
import pkgutil
from pathlib import Path

import numpy as np
import pytest

import judo
import judo.loop
import judo.runtime
from judo.evaluation.sensing import Sensing
from judo.loop.timing import ControlClock
from judo.runtime.app import App
from judo.runtime.app_state import AppState, PendingConfigs
from judo.runtime.session import ConfigSet

RUNTIME = Path(judo.runtime.__file__).parent
APP_PARTS = (
    "app",
    "app_state",
    "commands",
    "running/planner",
    "running/plant",
    "running/supervisor",
    "live_recording",
    "status",
    "session",
)
"""The modules of the App's parts."""
LIBRARY_SETTERS = {"config"}
"""Attributes of library objects (controller, optimizer, task, estimator) that are theirs to be
assigned: the documented live edit of a config, which each object checks and takes over itself."""


def runtime_modules():
    for info in pkgutil.walk_packages([str(RUNTIME)], "judo.runtime."):
        yield importlib.import_module(info.name)


def is_interface(cls: type) -> bool:
    return bool(getattr(cls, "_is_protocol", False)) or isinstance(cls, abc.ABCMeta)


def test_no_runtime_class_inherits_from_another_runtime_class_except_abcs_and_protocols():
    inherited = []
    for module in runtime_modules():
        for name, cls in inspect.getmembers(module, inspect.isclass):
            if cls.__module__ != module.__name__:
                continue
            for base in cls.__mro__[1:]:
                if base.__module__.startswith("judo.runtime") and not is_interface(base):
                    inherited.append(
                        f"{module.__name__}.{name} inherits {base.__module__}.{base.__qualname__}"
                    )
    assert not inherited, "\n".join(inherited)


def foreign_attribute_writes(path: Path) -> list[str]:
    """`x.attr = ...` (and augmented or tuple targets) in `path` where x is not `self` or an
    attribute of it, as 'file:line x.attr'."""
    writes = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Assign | ast.AugAssign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                for leaf in target.elts if isinstance(target, ast.Tuple) else [target]:
                    if not isinstance(leaf, ast.Attribute) or leaf.attr in LIBRARY_SETTERS:
                        continue
                    if root_name(leaf) != "self":
                        writes.append(f"{path.name}:{node.lineno} {ast.unparse(leaf)}")
    return writes


def root_name(node: ast.expr) -> str | None:
    """`self` for self.a.b: the name an attribute chain starts from (a record a class holds is its
    own)."""
    while isinstance(node, ast.Attribute | ast.Subscript):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


def test_the_apps_parts_and_the_closed_loop_write_only_their_own_attributes():
    paths = [RUNTIME / f"{part}.py" for part in APP_PARTS] + [
        Path(judo.loop.__file__).parent / "closed_loop.py"
    ]
    writes = [write for path in paths for write in foreign_attribute_writes(path)]
    assert not writes, "attributes written outside their class:\n" + "\n".join(writes)


def test_the_attribute_scan_sees_a_foreign_write(tmp_path):
    source = tmp_path / "part.py"
    source.write_text(
        "class A:\n    def f(self, state):\n        self.x.y = 1\n        state.y, z = 2, 3\n"
    )
    assert foreign_attribute_writes(source) == ["part.py:4 state.y"]


def test_the_app_never_imports_the_gui_or_collection():
    for module in runtime_modules():
        if module.__name__.startswith("judo.runtime.gui"):
            continue
        tree = ast.parse(Path(module.__file__).read_text())
        names = {
            alias.name
            for node in ast.walk(tree)
            if isinstance(node, ast.Import)
            for alias in node.names
        }
        names |= {node.module or "" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
        assert not {n for n in names if n.startswith(("judo.runtime.gui", "judo.collection"))}, (
            module.__name__
        )


def test_the_control_clock_ticks_every_period_and_after_a_late_plan():
    clock = ControlClock()
    assert clock.due(-1e9, 0.1)  # before a restart every time is due
    clock.restart(1.0)
    assert clock.due(1.0, 0.1) and not clock.due(0.99, 0.1)
    clock.ticked(1.0, 0.02, 0.1)
    assert clock.next_time(0.1) == pytest.approx(1.1) and not clock.due(1.05, 0.1)
    # an edit of control_freq takes effect at once
    assert clock.next_time(0.01) == pytest.approx(1.02)
    clock.ticked(1.1, 0.35, 0.1)  # a plan that takes effect after the next tick moves it
    assert clock.next_time(0.1) == pytest.approx(1.45) and clock.remaining(
        1.4, 0.1
    ) == pytest.approx(0.05)
    clock.ticked(1.45, 0.0, 0.1)
    assert clock.next_time(0.1) == pytest.approx(1.55)
    assert ControlClock().next_time(0.1) == -math.inf


def test_the_state_merges_requests_until_taken():
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    state: AppState = app._state
    state.request_switch(task="pendulum")
    state.request_switch(optimizer="cem")
    state.request_reset(from_user=False)
    state.request_reset(from_user=True)
    state.request_goal_move(0, np.zeros(3), None)
    config = app.commands.update_config("optimizer", {"num_rollouts": 12})
    planner = state.take_planner_requests()
    assert planner.switch == ("pendulum", "cem") and planner.configs.optimizer is config
    assert (
        state.take_planner_requests().switch is None
        and not state.take_planner_requests().configs.any()
    )
    plant = state.take_plant_requests()
    assert plant.reset and plant.reset_from_user and list(plant.goal_moves) == [0]
    assert not state.take_plant_requests().reset
    state.note_plant_reset()
    assert state.resets_done == 1 and state.take_planner_requests().forget_plans
    app.stop()


def test_a_config_set_keeps_each_kind_typed():
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    configs = ConfigSet.of(app.session)
    assert configs.as_dict() == app.configs()
    assert ConfigSet.from_dict(configs.as_dict()) == configs
    with pytest.raises(TypeError, match="the task config must be a TaskConfig"):
        ConfigSet.from_dict({**configs.as_dict(), "task": configs.optimizer})
    assert not PendingConfigs().any() and PendingConfigs(task=configs.task).any()
    assert AppState(Sensing()).paused is False
    app.stop()


class ListRecorder:
    """A recorder of the running app that keeps everything in lists (any LiveRecorder will do)."""

    def __init__(self, session, path):
        self.session, self.path = session, path
        self.steps, self.plans, self.edits, self.finished = [], [], [], False

    @property
    def num_steps(self):
        return len(self.steps)

    def on_plan(self, record):
        self.plans.append(record)

    def on_step(self, record):
        self.steps.append(record)

    def on_config(self, kind, config, **details):
        self.edits.append(kind)

    def move_to(self, session):
        self.session = session

    def finish(self):
        self.finished = True
        return self.path, 0


def test_any_recorder_can_be_injected(tmp_path, wait_until):
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    recorder = ListRecorder(app.session, tmp_path / "list")
    app.start()
    try:
        assert (
            app.start_recording(recorder) == tmp_path / "list"
            and app.recording == tmp_path / "list"
        )
        app.commands.update_config("task", {"w_vertical": 2.0})
        wait_until(lambda: recorder.num_steps > 10 and recorder.plans, timeout=20)
        assert (
            app.stop_recording() == tmp_path / "list"
            and recorder.finished
            and recorder.edits == ["task"]
        )
        assert app.recording is None
        stranger = ListRecorder(object(), tmp_path / "other")
        with pytest.raises(judo.JudoError, match="records another session"):
            app.start_recording(stranger)
    finally:
        app.stop()


def test_a_frontend_is_given_to_the_app_and_drawn_on_its_loop(wait_until):
    class CountingFrontend:
        def __init__(self, port):
            self.port, self.frames, self.closed, self.url = port, 0, False, "counting://"

        def update(self):
            self.frames += 1
            assert self.port.session.task_name == "cartpole"

        def close(self):
            self.closed = True

    app = App("cartpole", "ps", gui=CountingFrontend, seed=0, num_workers=1)
    app.start()
    try:
        frontend = app.gui
        assert isinstance(frontend, CountingFrontend) and frontend.port is app
        wait_until(lambda: frontend.frames >= 3, timeout=10)
    finally:
        app.stop()
    assert frontend.closed and app.gui is frontend
