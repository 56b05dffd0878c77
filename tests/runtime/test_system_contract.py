"""A user System is checked where it meets the app: a read_state() of the wrong type is named in one
line, and a System without halt() is warned about at start-up (a blocked driver cannot be brought to
rest without it)."""

import logging

import numpy as np
import pytest

import judo
from judo.core.errors import JudoError
from judo.core.reading import SystemState
from judo.loop.system import MujocoSystem, System, SystemCalls, SystemReadingError
from judo.runtime.app import App


class Driver(System):
    """The simulated cartpole behind a user driver; `wrong_reading` makes read_state return a plain
    dict."""

    def __init__(self, wrong_reading: bool = False) -> None:
        with judo.make_controller("cartpole", "ps", seed=0) as controller:
            self.plant = MujocoSystem.from_task(controller.task, seed=0)
        self.timestep = self.plant.timestep
        self.wrong_reading = wrong_reading

    def reset(self) -> None:
        self.plant.reset()

    def read_state(self) -> SystemState:
        reading = self.plant.read_state()
        if self.wrong_reading:
            return {"state": reading.state, "time": reading.time}  # type: ignore[return-value]
        return reading

    def apply(self, action: np.ndarray) -> None:
        self.plant.apply(action)

    def step(self) -> None:
        self.plant.step()


class HaltingDriver(Driver):
    def halt(self) -> bool:
        self.plant.apply(np.zeros(1))
        return True


WRONG = (
    "Driver.read_state() returned dict; expected a judo.SystemState (state, time, metadata, "
    "sensors)"
)


def test_a_reading_of_the_wrong_type_is_named_in_one_line():
    with pytest.raises(SystemReadingError) as caught:
        App("cartpole", "ps", system=Driver(wrong_reading=True), gui=False)
    assert str(caught.value) == WRONG
    with pytest.raises(
        SystemReadingError, match=f"^{WRONG}$".replace("(", r"\(").replace(")", r"\)")
    ):
        # every read of the running loop goes through it
        SystemCalls(Driver(wrong_reading=True)).read_state()


def test_a_system_without_halt_is_warned_about_at_start_up_and_one_with_halt_is_not(caplog):
    with caplog.at_level(logging.WARNING, logger="judo.app"):
        App("cartpole", "ps", system=Driver(), gui=False)
    warnings = [
        record.getMessage() for record in caplog.records if record.levelno == logging.WARNING
    ]
    assert warnings == [
        "your System Driver defines no halt(): while a call into it blocks, nothing reaches "
        "the robot, which keeps "
        "its last action until the call returns; define halt() to bring it to rest from "
        "another thread "
        "(docs/hardware.md)"
    ]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="judo.app"):
        App("cartpole", "ps", system=HaltingDriver(), gui=False)
        App("cartpole", "ps", gui=False)  # judo's own simulator needs none
    assert [record for record in caplog.records if "halt()" in record.getMessage()] == []


def test_a_goal_moves_through_the_system_and_one_without_move_goal_refuses_it():
    with judo.make_controller("car", "ps", seed=0) as controller:
        plant = MujocoSystem.from_task(controller.task, seed=0)
    plant.move_goal(0, np.array([1.0, 2.0, 0.0]), np.array([2.0, 0.0, 0.0, 0.0]))
    metadata = plant.read_state().metadata  # the reading carries the goal back
    assert metadata["mocap_pos"][0].tolist() == [1.0, 2.0, 0.0] and metadata["mocap_quat"][
        0
    ].tolist() == [1, 0, 0, 0]
    with pytest.raises(
        JudoError, match="Driver cannot move goals: it does not implement System.move_goal"
    ):
        Driver().move_goal(0, np.zeros(3))
    app = App("cartpole", "ps", gui=False, system=Driver(), seed=0, num_workers=1)
    try:
        with pytest.raises(JudoError, match="your Driver has no System.move_goal"):
            app.commands.move_goal(0, np.zeros(3))
    finally:
        app.session.close()
