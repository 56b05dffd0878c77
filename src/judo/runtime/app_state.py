"""The app's shared state: one object, one lock, every field written through its methods.

The App's parts (`judo.runtime.app`) share one `AppState` and take what is theirs from it:
- the commands (any thread: the GUI's callbacks, a notebook) validate, then `accept_config`,
  `request_*`, `pause`, `resume`;
- the plant runner (`judo.runtime.running.plant`, the System's thread) takes the plant's requests
  (`take_plant_requests`, when `plant_pending`) and counts the resets it carries out;
- the planner runner (`judo.runtime.running.planner`) takes the planner's requests
  (`take_planner_requests`, when `planner_pending`), makes each planning cycle the one in flight
  (`in_flight`) and installs a new session on a switch (`install_session`); it is the only writer of
  the session's configs.

What the GUI (or a notebook) follows arrives by callback, fired on the thread that made the change,
under the lock: `config_changed(kind, config, from_gui)` for each accepted config,
`plant_reset(resets_done)` after each reset the plant carried out, `session_changed(session)` after
a switch and `recording_changed(recorder or None)` when a recording begins or ends
(`judo.runtime.snapshots.Subscribers`).

Reads of a single field (`session`, `paused`, `resets_done`, `in_flight.cycle`, and the flags
`plant_pending` and `planner_pending` that say requests wait) need no lock: each is one reference,
replaced whole. Everything read or written together is taken under `lock`. The runners look at the
flags on every tick and take the requests only when one is up, so a steady-state tick runs no code
here.

`stop` is the app's `StopSignal` (`judo.runtime.exchange`): one flag that every thread polls and
every asyncio wait is cut short by.
"""

import math
import threading
import time
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from judo.core.configuration.config import Config
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import ConfigKind
from judo.core.estimator import EstimatorConfig
from judo.core.optimizer import OptimizerConfig
from judo.core.task import TaskConfig
from judo.evaluation.sensing import Sensing
from judo.recording.live import LiveRecorder
from judo.runtime.exchange import (
    CycleInFlight,
    PlanningCycle,
    StepCost,
    StopSignal,
    cycle_seconds,
)
from judo.runtime.session import ConfigSet, Session
from judo.runtime.snapshots import CycleCost, Subscribers


class PausableClock:
    """Wall-clock seconds (monotonic) that stand still while paused: the app's watchdog clock, so a
    pause does not age the plan in force."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._paused_at: float | None = None
        self._paused_for = 0.0

    def __call__(self) -> float:
        with self._lock:
            now = self._paused_at if self._paused_at is not None else time.monotonic()
            return now - self._paused_for

    def pause(self) -> None:
        with self._lock:
            if self._paused_at is None:
                self._paused_at = time.monotonic()

    def resume(self) -> None:
        with self._lock:
            if self._paused_at is not None:
                self._paused_for += time.monotonic() - self._paused_at
                self._paused_at = None


@dataclass
class PendingConfigs:
    """Configs accepted since the planner last took them: one optional field per kind (None: no
    edit)."""

    controller: ControllerConfig | None = None
    optimizer: OptimizerConfig | None = None
    task: TaskConfig | None = None

    def any(self) -> bool:
        return any(getattr(self, f.name) is not None for f in fields(self))


@dataclass
class PlantRequests:
    """What the plant runner carries out before its next step."""

    reset: bool = False
    reset_from_user: bool = False  # the reset was asked for (reported), not made by a divergence
    # index -> pos, quat
    goal_moves: dict[int, tuple[np.ndarray, np.ndarray | None]] = field(default_factory=dict)


@dataclass
class PlannerRequests:
    """What the planner runner carries out at the top of its next cycle."""

    switch: tuple[str, str] | None = None  # (task, optimizer)
    rebuild: bool = False  # rebuild the session even with the same names (a switch of estimator)
    forget_plans: bool = False  # the plant was reset (or diverged): plan afresh
    configs: PendingConfigs = field(default_factory=PendingConfigs)


class AppState:
    """The state an App's parts share (see the module's docstring).

    Args:
        sensing: how the simulated plant is observed and which estimator runs, kept across switches.

    `begin(session)` gives it the first session; no part runs before.
    """

    def __init__(self, sensing: Sensing) -> None:
        self.lock = threading.RLock()
        self.stop = StopSignal()  # set once, from any thread, to stop every part
        self.session: Session  # the session in use, from `begin`
        self.configs: ConfigSet  # the latest accepted configs, from `begin`
        self.sensing = sensing
        # the watchdog's wall clock for a user's System: stands still while paused
        self.clock = PausableClock()
        self.clock.resume()
        self.paused = False
        # plant resets carried out; a plan stamped with fewer is of the plant before a reset
        self.resets_done = 0
        self.recording: LiveRecorder | None = None
        self.config_changed = Subscribers()  # (kind, config, from_gui) for each config accepted
        self.plant_reset = Subscribers()  # (resets_done) after each reset the plant carried out
        self.session_changed = Subscribers()  # (session) after a switch
        # (recorder, or None) when a recording begins or ends
        self.recording_changed = Subscribers()
        # the planning cycle in flight (the planner runner starts each one)
        self.in_flight = CycleInFlight()
        self.step_cost: StepCost  # the session's cost of one rollout step, from `begin`
        self._plant = PlantRequests()
        self._planner = PlannerRequests()
        self.plant_pending = False  # the plant's requests wait to be taken
        self.planner_pending = False  # the planner's requests wait to be taken

    def begin(self, session: Session) -> None:
        """Start with `session` and its configs."""
        cost = session_step_cost(session)
        with self.lock:
            self.session, self.configs, self.step_cost = session, ConfigSet.of(session), cost

    # ---- configs ---------------------------------------------------------------------------------
    def accept_config(self, kind: ConfigKind, config: Config, *, from_gui: bool) -> None:
        """Put `config` (validated by the caller under `lock`) in force from the planner's next
        cycle."""
        with self.lock:
            self.configs = self.configs.with_config(kind, config)
            setattr(self._planner.configs, kind, config)
            self.planner_pending = True
            if self.recording is not None:
                self.recording.on_config(kind, config)
            self.config_changed.fire(kind, config, from_gui)

    def accept_estimator_config(
        self, estimator: Any, config: EstimatorConfig, *, from_gui: bool
    ) -> None:
        """Hand `config` to the running `estimator` (its own hand-over takes effect before its next
        update)."""
        with self.lock:
            estimator.config = config
            if self.recording is not None:
                self.recording.on_config("estimator", config, name=self.session.estimator_name)
            self.config_changed.fire("estimator", config, from_gui)

    def reset_configs(self, defaults: ConfigSet) -> None:
        """Put `defaults` in force from the planner's next cycle (cancelling the cycle in
        flight)."""
        with self.lock:
            self.cancel_cycle("the configs were reset")
            self.configs = defaults
            self._planner.configs = PendingConfigs(
                defaults.controller, defaults.optimizer, defaults.task
            )
            self.planner_pending = True
            for kind, config in defaults.as_dict().items():
                self.config_changed.fire(kind, config, False)

    # ---- recording -------------------------------------------------------------------------------
    def begin_recording(self, recorder: LiveRecorder) -> None:
        """`recorder` hears every config edit from now on (`judo.runtime.live_recording`)."""
        with self.lock:
            self.recording = recorder
            self.recording_changed.fire(recorder)

    def end_recording(self) -> LiveRecorder | None:
        """The recorder under way, which hears no more edits; None when nothing records."""
        with self.lock:
            recorder, self.recording = self.recording, None
            if recorder is not None:
                self.recording_changed.fire(None)
        return recorder

    # ---- the planning cycle in flight ------------------------------------------------------------
    @property
    def cycle(self) -> PlanningCycle | None:
        """The planning cycle in flight, or None (`in_flight.cycle`)."""
        return self.in_flight.cycle

    def cancel_cycle(self, reason: str) -> None:
        """End the planning cycle in flight, if any, at its next check (the plan before stays in
        force)."""
        with self.lock:
            if (cycle := self.in_flight.cycle) is not None:
                cycle.cancel(reason)

    # ---- pause -----------------------------------------------------------------------------------
    def pause(self) -> None:
        with self.lock:
            self.cancel_cycle("paused")
            self.paused = True
            self.clock.pause()

    def resume(self) -> None:
        with self.lock:
            self.paused = False
            self.clock.resume()

    # ---- the plant's requests --------------------------------------------------------------------
    def request_reset(self, *, from_user: bool) -> None:
        """Reset the plant before its next step (and the plan once that worked)."""
        with self.lock:
            if from_user:  # a plan of the plant before the reset is of no use
                self.cancel_cycle("the task was reset")
            self._plant.reset = True
            self._plant.reset_from_user = self._plant.reset_from_user or from_user
            self.plant_pending = True

    def request_goal_move(self, index: int, position: np.ndarray, quat: np.ndarray | None) -> None:
        with self.lock:
            self._plant.goal_moves[index] = (position, quat)
            self.plant_pending = True

    def take_plant_requests(self) -> PlantRequests:
        """The plant's requests since the last take (the plant runner's, when `plant_pending`)."""
        with self.lock:
            requests, self._plant, self.plant_pending = self._plant, PlantRequests(), False
        return requests

    def note_plant_reset(self) -> None:
        """The plant was reset (or reset itself): count it, and have the planner forget its
        plans."""
        with self.lock:
            self.resets_done += 1
            self._planner.forget_plans = self.planner_pending = True
            self.plant_reset.fire(self.resets_done)

    def note_divergence(self) -> None:
        """The plant's simulation blew up and reset itself: the planner forgets its plans."""
        with self.lock:
            self._planner.forget_plans = self.planner_pending = True

    # ---- the planner's requests ------------------------------------------------------------------
    def request_switch(
        self, task: str | None = None, optimizer: str | None = None, *, rebuild: bool = False
    ) -> None:
        """Switch to `task` and/or `optimizer` (the names in use, or already asked for, where
        None)."""
        with self.lock:
            current = self._planner.switch or (self.session.task_name, self.session.optimizer_name)
            self._planner.switch = (task or current[0], optimizer or current[1])
            self.cancel_cycle(
                f"switching to {self._planner.switch[0]} with {self._planner.switch[1]}"
            )
            self._planner.rebuild = self._planner.rebuild or rebuild
            self.planner_pending = True

    def request_estimator(self, estimator: str | None, *, rebuild: bool) -> None:
        """Run `estimator` (None: none) in every session from now on, with its registered defaults;
        `rebuild` the running session for it."""
        with self.lock:
            self.sensing = replace(self.sensing, estimator=estimator, estimator_config=None)
            if rebuild:
                self.request_switch(rebuild=True)

    def take_planner_requests(self) -> PlannerRequests:
        """The planner's requests since the last take (the planner runner's, when
        `planner_pending`)."""
        with self.lock:
            requests, self._planner, self.planner_pending = self._planner, PlannerRequests(), False
        return requests

    def install_session(self, session: Session) -> None:
        """Use `session` from now on, with its own configs (the planner runner's, on a switch)."""
        cost = session_step_cost(session)
        with self.lock:
            self.session, self.step_cost = session, cost
            self.configs = ConfigSet.of(session)
            self._planner.configs = PendingConfigs()
            self.session_changed.fire(session)

    def planning_cost(self) -> CycleCost:
        """The planning cycle's size and estimated seconds under the latest configs, the last
        update's seconds, and the late cycle's seconds so far (`App.planning_cost`)."""
        with self.lock:
            session, configs, cycle, step_cost = (
                self.session,
                self.configs,
                self.cycle,
                self.step_cost,
            )
        size = session.controller.cycle_size(configs.as_dict())  # None: a policy rolls nothing out
        times = session.closed_loop.update_ms
        last = times[-1] / 1e3 if times else math.nan
        running = cycle.elapsed() if cycle is not None and cycle.late() else None
        estimate = math.nan if size is None else cycle_seconds(step_cost, size, configs.controller)
        return CycleCost(size, estimate, last, running)


def session_step_cost(session: Session) -> StepCost:
    """The cost of one rollout step of `session`'s controller: probed on its planning model on the
    CPU backend; measured from cycles only on another backend, and unknown where a policy drives (no
    rollouts)."""
    controller = session.controller
    # None where a policy plans
    workers = 1 if controller.backend is None else controller.backend.num_workers
    return StepCost(controller.task.model, workers, probe=controller.backend_name == "cpu")
