"""The command port: all the browser GUI sees of the app, and the status types both sides share.

The GUI (`judo.runtime.gui`) imports this module and never `judo.runtime.app`; `App` implements
`AppPort`. What goes through the port, and nothing else:
- read-only status: the session in use, the latest configs, the snapshots the loops publish, the
  live figures, the status line and a few counters that tell the GUI when to redraw;
- commands, callable from any thread (the GUI's callbacks run on viser's): config edits, pause and
  resume, resets, goal moves, switches of task or optimizer, and status reports. Each is queued and
  carried out by the app's loops at their next iteration.

The loops publish under two topics of the app's StateBuffer: "system" a `SystemSnapshot`, "plan" a
`PlanSnapshot`.
"""

from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from judo.core.config import Config
from judo.core.estimator import EstimatorConfig
from judo.core.registry import CONFIG_KINDS, ConfigKind
from judo.loop.records import LiveRecorder
from judo.loop.system import SystemState
from judo.runtime.cycles import CycleCost
from judo.runtime.session import POLICY_OPTIMIZER, Session
from judo.runtime.snapshots import PlanSnapshot, Snapshot, SystemSnapshot
from judo.runtime.status import Level as StatusLevel
from judo.runtime.status import LiveFigures, Status

__all__ = [
    "CONFIG_KINDS",
    "POLICY_OPTIMIZER",
    "AppPort",
    "ConfigKind",
    "CycleCost",
    "FigureSource",
    "LiveFigures",
    "PlanSnapshot",
    "Session",
    "Snapshot",
    "SnapshotSource",
    "Status",
    "StatusLevel",
    "SystemSnapshot",
    "SystemState",
]


class SnapshotSource(Protocol):
    """The reading side of the app's StateBuffer."""

    def latest(self, topic: str) -> Snapshot[Any] | None:
        """The newest snapshot of `topic` ("system": SystemSnapshot, "plan": PlanSnapshot), or None."""
        ...


class FigureSource(Protocol):
    """The reading side of the app's RunStats."""

    def live(self) -> LiveFigures:
        """The latest plan time, control rate, real-time factor and nominal reward."""
        ...


@runtime_checkable
class AppPort(Protocol):
    """The commands and read-only status the GUI uses; `judo.App` implements it."""

    @property
    def session(self) -> Session:
        """The session in use (names, generation, controller); replaced, never changed, on a switch."""
        ...

    @property
    def policy_name(self) -> str | None:
        """The name of the policy the app can serve as its controller (its optimizer dropdown's "policy"), or None."""
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

    @property
    def resets_done(self) -> int:
        """Counts plant resets carried out, so the GUI knows when to reframe its camera."""
        ...

    @property
    def external_edits(self) -> int:
        """Counts config changes not made through the GUI, so the GUI knows when to refresh its widgets."""
        ...

    def configs(self) -> dict[ConfigKind, Config]:
        """The latest accepted config of each kind."""
        ...

    def planning_cost(self) -> CycleCost:
        """The planning cycle's size and estimated seconds under the latest configs, the last update's seconds, and
        how long the cycle in flight has run once it is late."""
        ...

    def update_config(
        self, kind: ConfigKind, updates: dict[str, Any], *, generation: int | None = None, from_gui: bool = False
    ) -> Config:
        """Validate {field: value} `updates` to the `kind` config and queue it; raises JudoError if refused."""
        ...

    def update_estimator_config(
        self, updates: dict[str, Any], *, generation: int | None = None, from_gui: bool = False
    ) -> EstimatorConfig:
        """Validate {field: value} `updates` to the running estimator's config (`session.closed_loop.estimator`)
        and use it from its next update; raises JudoError if refused or no estimator runs."""
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
        """Move mocap body `index` to `position` (3,), turned to `quat` (4,) wxyz if given; raises JudoError."""
        ...

    def switch_task(self, task: str) -> None:
        """Use the registered task `task` from the next cycle; raises JudoError if refused."""
        ...

    def switch_estimator(self, estimator: str | None) -> None:
        """Run the registered estimator `estimator` (None: none) from the next cycle; raises JudoError if refused."""
        ...

    def switch_optimizer(self, optimizer: str) -> None:
        """Use the registered optimizer `optimizer` from the next cycle; raises JudoError if unknown."""
        ...

    def report(self, message: str, level: StatusLevel = "info") -> None:
        """Show `message` on the status line and write it to the log."""
        ...

    @property
    def recording(self) -> Path | None:
        """The file a recording under way will be written to, or None."""
        ...

    @property
    def recording_changes(self) -> int:
        """Recordings begun and ended so far."""
        ...

    def start_recording(self, recorder: LiveRecorder | str | Path | None = None) -> Path:
        """Record every step, plan and config edit with `recorder`, or into the file `recorder` names with the
        app's recorder factory (by default an HDF5 file in the collect layout); returns the file."""
        ...

    def stop_recording(self) -> Path | None:
        """Write the recording under way as the next demo of its file; returns the file, or None."""
        ...
