"""The command port: all the browser GUI sees of the app, and the status types both sides share.

The GUI (`judo.runtime.gui`) imports this module and never `judo.runtime.app`; `App` implements
`AppPort`. What goes through the port, and nothing else:
- read-only status: the session in use, the latest configs, the snapshots the loops publish, the
  live figures and the status line;
- news by callback (`on_state`, `on_plan`, `on_config_change`, `on_reset`, `on_session`,
  `on_recording`, `on_status`), called on the thread that made it: a callback keeps the newest value
  and returns at once;
- commands, callable from any thread (the GUI's callbacks run on viser's): config edits, pause and
  resume, resets, goal moves, switches of task or optimizer, and status reports. Each is queued and
  carried out by the app's loops at their next iteration (`judo.runtime.commands.Commands`).

The loops publish under two topics of the app's StateBuffer: "system" a `SystemSnapshot`, "plan" a
`PlanSnapshot`.
"""

from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from judo.core.configuration.config import Config
from judo.core.configuration.registry import ConfigKind
from judo.core.estimator import EstimatorConfig
from judo.recording.live import LiveRecorder
from judo.runtime.session import Session
from judo.runtime.snapshots import CycleCost, LiveFigures, PlanSnapshot, Snapshot, SystemSnapshot
from judo.runtime.status import Level as StatusLevel
from judo.runtime.status import Status
from judo.safety.stop import StopLatch

__all__ = ["AppPort", "CommandPort", "FigureSource", "SnapshotSource"]


class SnapshotSource(Protocol):
    """The reading side of the app's StateBuffer."""

    def latest(self, topic: str) -> Snapshot[Any] | None:
        """The newest snapshot of `topic` ("system": SystemSnapshot, "plan": PlanSnapshot), or
        None."""
        ...


class FigureSource(Protocol):
    """The reading side of the app's RunStats."""

    def live(self) -> LiveFigures:
        """The latest plan time, control rate, real-time factor and nominal reward."""
        ...


class CommandPort(Protocol):
    """What a running app is asked to do, from any thread: `App.commands` (a `Commands`)."""

    def update_config(
        self,
        kind: ConfigKind,
        updates: dict[str, Any],
        *,
        generation: int | None = None,
        from_gui: bool = False,
    ) -> Config:
        """Validate {field: value} `updates` to the `kind` config and queue it; raises JudoError if
        refused."""
        ...

    def update_estimator_config(
        self, updates: dict[str, Any], *, generation: int | None = None, from_gui: bool = False
    ) -> EstimatorConfig:
        """Validate {field: value} `updates` to the running estimator's config
        (`session.closed_loop.estimator`) and use it from its next update; raises JudoError if
        refused or no estimator runs."""
        ...

    def reset_configs(self) -> None:
        """Put every config back to the task's registered defaults."""
        ...

    def pause(self) -> None:
        """Freeze the plant and the planner."""
        ...

    def resume(self) -> None:
        """Undo `pause()`."""
        ...

    def reset_task(self) -> None:
        """Reset the plant to its start state and forget the plan."""
        ...

    def move_goal(self, index: int, position: np.ndarray, quat: np.ndarray | None = None) -> None:
        """Move mocap body `index` to `position` (3,), turned to `quat` (4,) wxyz if given; raises
        JudoError."""
        ...

    def switch_task(self, task: str) -> None:
        """Use the registered task `task` from the next cycle; raises JudoError if refused."""
        ...

    def switch_estimator(self, estimator: str | None) -> None:
        """Run the registered estimator `estimator` (None: none) from the next cycle; raises
        JudoError if refused."""
        ...

    def switch_optimizer(self, optimizer: str) -> None:
        """Use the registered optimizer `optimizer` from the next cycle; raises JudoError if
        unknown."""
        ...


@runtime_checkable
class AppPort(Protocol):
    """The commands and read-only status the GUI uses; `judo.App` implements it."""

    @property
    def session(self) -> Session:
        """The session in use (names, generation, controller); replaced, never changed, on a
        switch."""
        ...

    @property
    def policy_name(self) -> str | None:
        """The name of the policy the app can serve as its controller (its optimizer dropdown's
        "policy"), or None."""
        ...

    @property
    def buffer(self) -> SnapshotSource:
        """The latest "system" and "plan" snapshots."""
        ...

    @property
    def stats(self) -> FigureSource:
        """The live figures for the plots and the readout."""
        ...

    @property
    def paused(self) -> bool:
        """True while the plant and the planner are paused."""
        ...

    @property
    def status(self) -> Status:
        """The latest status message."""
        ...

    def on_state(self, callback: Callable[[Snapshot[SystemSnapshot]], None]) -> None:
        """Call `callback(snapshot)` with each plant reading published, on the plant's thread."""
        ...

    def on_plan(self, callback: Callable[[Snapshot[PlanSnapshot]], None]) -> None:
        """Call `callback(snapshot)` with each plan published, on the planner's thread."""
        ...

    def on_config_change(self, callback: Callable[[str, Config, bool], None]) -> None:
        """Call `callback(kind, config, from_gui)` with each config accepted, on the thread of the
        command."""
        ...

    def on_reset(self, callback: Callable[[int], None]) -> None:
        """Call `callback(resets_done)` after each reset the plant carried out, on the plant's
        thread."""
        ...

    def on_session(self, callback: Callable[[Session], None]) -> None:
        """Call `callback(session)` once a switch installed the new session, on the planner's
        thread."""
        ...

    def on_recording(self, callback: Callable[[Path | None], None]) -> None:
        """Call `callback(path)` when a recording begins (its file) or ends (None)."""
        ...

    def on_status(self, callback: Callable[[Status], None]) -> None:
        """Call `callback(status)` with each new status line, on the thread that reported it."""
        ...

    def configs(self) -> dict[ConfigKind, Config]:
        """The latest accepted config of each kind."""
        ...

    def planning_cost(self) -> CycleCost:
        """The planning cycle's size and estimated seconds under the latest configs, the last
        update's seconds, and how long the cycle in flight has run once it is late."""
        ...

    @property
    def commands(self) -> "CommandPort":
        """The commands (config edits, pause, resets, goal moves, switches), callable from any
        thread."""
        ...

    def report(self, message: str, level: StatusLevel = "info") -> None:
        """Show `message` on the status line and write it to the log."""
        ...

    @property
    def recording(self) -> Path | None:
        """The file a recording under way will be written to, or None."""
        ...

    def start_recording(self, recorder: LiveRecorder | str | Path | None = None) -> Path:
        """Record every step, plan and config edit with `recorder`, or into the file `recorder`
        names with the app's recorder factory (by default an HDF5 file in the collect layout);
        returns the file."""
        ...

    def stop_recording(self) -> Path | None:
        """Write the recording under way as the next demo of its file; returns the file, or None."""
        ...

    @property
    def stop_latch(self) -> StopLatch:
        """The latched stop (`judo.safety.stop`): whether it is engaged, and its engage and clear
        (any thread)."""
        ...
