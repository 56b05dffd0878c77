"""The App's commands: what the GUI, a notebook or a script asks of a running app, from any thread.

Each command validates at once (raising UnknownNameError, ConfigError or JudoError) and only queues its
request under the app's lock; the loops (`judo.runtime.loops`, `judo.runtime.plant_loop`) carry it out at
the top of their next iteration. `AppCommands` is the App's base class (see `judo.runtime.app.App`).
"""

from dataclasses import replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from judo.core.config import Config, with_updates
from judo.core.controller import check_configs
from judo.core.errors import ConfigError, JudoError
from judo.core.estimator import EstimatorConfig
from judo.core.proposals import check_proposal_policy
from judo.core.registry import (
    CONFIG_KINDS,
    ConfigKind,
    default_configs,
    lookup_optimizer,
    lookup_task,
    make_estimator,
)
from judo.runtime.event_loop import AppEventLoop
from judo.runtime.session import check_estimator
from judo.runtime.watchdog import PausableClock


class AppCommands(AppEventLoop):
    """Config edits, pause and resume, resets, goal moves, switches and recording (see `judo.runtime.app.App`)."""

    _clock: PausableClock
    _rebuild_requested: bool  # a switch of estimator: rebuild the session even with the same names
    _recording: Any  # the LiveRecording under way (judo.collection.live), or None

    @property
    def recording(self) -> Path | None:
        """The file a recording under way will be written to, or None."""
        recording = self._recording
        return None if recording is None else recording.path

    def start_recording(self, path: str | Path | None = None) -> Path:
        """Record every step, plan and config edit (the estimator's, and a change of estimator, too) of the
        running session until `stop_recording()` (or a switch of task or optimizer) into `path` (an HDF5 file
        in the collect layout, docs/collect.md; judo-recording-TASK-TIME.h5 by default). Needs the `collect`
        extra (h5py). Returns the path."""
        from judo.collection.live import LiveRecording, default_recording_path  # h5py only when asked for

        with self._lock:
            if self._recording is not None:
                raise JudoError(f"already recording to {self._recording.path}; stop that recording first")
            session = self._session
            recording = LiveRecording(path or default_recording_path(session.task_name), session, dict(self._configs))
            session.closed_loop.recorders.append(recording)
            self._recording = recording
        self.report(f"recording to {recording.path}")
        return recording.path

    def stop_recording(self) -> Path | None:
        """Stop the recording under way and write it as the next demo of its file (`python -m judo replay
        FILE` plays it); returns the file, or None when nothing was recording. Raises JudoError if the
        file cannot be written."""
        with self._lock:
            recording, self._recording = self._recording, None
        if recording is None:
            return None
        if recording in recording.session.closed_loop.recorders:
            recording.session.closed_loop.recorders.remove(recording)
        path, index = recording.finish()
        self.report(
            f"recorded {recording.num_steps} steps to {path} as demo_{index}; replay: python -m judo replay {path}"
        )
        return path

    def update_config(
        self, kind: ConfigKind, updates: dict[str, Any], *, generation: int | None = None, from_gui: bool = False
    ) -> Config:
        """Validate `updates` ({field: value}) to the `kind` config and queue it for the next cycle.

        Returns the new config. Raises UnknownNameError or ConfigError, keeping the previous config,
        if a field does not exist, a value is invalid, or the configs would not work together (e.g.
        num_rollouts 0, a horizon shorter than one timestep). `generation` (from `session`) refuses
        an edit made for a session that has since been replaced.
        """
        if kind not in CONFIG_KINDS:
            raise ConfigError(f"config kind must be one of {list(CONFIG_KINDS)}, got {kind!r}")
        with self._lock:
            if generation is not None and generation != self._session.generation:
                raise ConfigError("the task or optimizer changed since this edit was made; it was not applied")
            updated = with_updates(self._configs[kind], updates)
            candidate = {**self._configs, kind: updated}
            check_configs(self._session.controller.task, candidate["controller"], candidate["optimizer"])  # type: ignore[arg-type]
            proposals = getattr(self._session.controller, "proposal_policy", None)  # refused here, not every cycle
            check_proposal_policy(proposals, getattr(candidate["controller"], "policy_samples", 0))
            self._configs[kind] = updated
            self._pending[kind] = updated
            if not from_gui:
                self._external_edits += 1
            if self._recording is not None:
                self._recording.on_config(kind, updated)
            task = self._session.controller.task
        rate = getattr(updated, "control_freq", None)
        if kind == "controller" and rate is not None and rate < type(task).min_control_freq:
            self.report(
                f"control_freq {rate:g} Hz is below the {type(task).min_control_freq:g} Hz that {type(task).__name__}'s "
                "defaults need (docs/tasks.md); expect it to fail",
                "warning",
            )
        return updated

    def update_estimator_config(
        self, updates: dict[str, Any], *, generation: int | None = None, from_gui: bool = False
    ) -> EstimatorConfig:
        """Validate `updates` ({field: value}) to the running estimator's config and use it from its next
        update. Returns the new config. Raises ConfigError, keeping the config before, for an unknown field
        or a bad value, and JudoError when no estimator runs or the session changed (`generation`)."""
        with self._lock:
            session = self._session
            if generation is not None and generation != session.generation:
                raise ConfigError("the task or optimizer changed since this edit was made; it was not applied")
            estimator = session.closed_loop.estimator
            if estimator is None:
                raise JudoError(
                    "no estimator runs: the app plans from the plant's full state; start it with "
                    "estimator='ekf' (or observe='sensors') to have one"
                )
            updated = with_updates(estimator.config, updates)
            estimator.config = updated  # handed to the filter before its next update, on its own thread
            if not from_gui:
                self._external_edits += 1
            if self._recording is not None:
                self._recording.on_config("estimator", updated, name=session.estimator_name)
        return updated

    def reset_configs(self) -> None:
        """Put every config back to the task's registered defaults (at the next cycle)."""
        with self._lock:
            session = self._session
            self._configs = default_configs(session.task_name, session.optimizer_name)  # type: ignore[assignment]
            self._pending = dict(self._configs)
            self._external_edits += 1
        self.report("configs reset to the defaults")

    def pause(self) -> None:
        """Freeze the plant and the planner (a paused simulation keeps its time)."""
        self._paused = True
        self._clock.pause()
        self.report("paused")

    def resume(self) -> None:
        """Undo `pause()`."""
        self._paused = False
        self._clock.resume()
        self.report(self._running_message())

    def reset_task(self) -> None:
        """Reset the plant to its start state and forget the plan."""
        with self._lock:  # the plan is forgotten once the plant's reset worked
            self._reset_system = self._reset_from_user = True

    def move_goal(self, index: int, position: np.ndarray, quat: np.ndarray | None = None) -> None:
        """Move mocap body `index` (a goal) of the simulated plant to `position` (3,), and turn it to
        `quat` (4,) wxyz if given, before its next step.

        The planner sees it with the next state (the plant publishes its mocap poses). Raises JudoError
        for a user's System, whose goals the app cannot move, or an index the model does not have.
        """
        plant = self._session.simulated
        if plant is None:
            raise JudoError(f"cannot move goal {index}: the app drives your own {type(self._session.system).__name__}")
        nmocap = plant.task.sim_model.nmocap
        if not 0 <= index < nmocap:
            raise JudoError(f"goal index must be in [0, {nmocap}), got {index}")
        try:
            moved = np.array(position, dtype=float).reshape(3)
            turn = None if quat is None else np.array(quat, dtype=float).reshape(4)
        except (TypeError, ValueError) as err:
            raise JudoError(f"goal {index}: a position needs 3 numbers and a quat 4: {err}") from None
        if not np.isfinite(moved).all() or (turn is not None and not (np.isfinite(turn).all() and turn.any())):
            raise JudoError(f"goal {index} not moved: position {moved.tolist()} and quat must be finite (quat not 0)")
        with self._lock:
            self._goal_moves[index] = (moved, turn)

    def switch_task(self, task: str) -> None:
        """Use the registered task `task` from the next cycle, with its default configs."""
        lookup_task(task)
        if self._user_system is not None and task != self._session.task_name:
            raise JudoError(
                f"cannot switch to task {task!r}: the app drives your own System, which is "
                f"{self._session.task_name!r}; start a new App for another task"
            )
        with self._lock:
            optimizer = self._switch_request[1] if self._switch_request else self._session.optimizer_name
            self._switch_request = (task, optimizer)

    def switch_estimator(self, estimator: str | None) -> None:
        """Run the registered estimator `estimator` (None: none, planning from full-state readings as they are)
        from the next cycle, keeping the plant running: restarted from the next reading, with its registered
        defaults (its live config when it is the one running). Raises UnknownNameError for
        an unregistered name, JudoError when the plant's readings lack what it needs (a full state)."""
        session = self._session
        if estimator is not None:  # tried on the plant's latest reading (its own thread may be reading it now)
            latest = session.closed_loop.raw_reading or session.system.read_state()
            check_estimator(estimator, make_estimator(estimator, session.controller.task), latest)
        with self._lock:
            raw = session.closed_loop.raw_reading
            if estimator is None and raw is not None and raw.state is None:
                raise JudoError(
                    "cannot plan without an estimator: the plant measures only sensors (state None); choose "
                    "an estimator that fuses them, e.g. 'ekf'"
                )
            self._sensing = replace(self._sensing, estimator=estimator, estimator_config=None)
            if estimator is None and session.estimator_name is None:
                return
            if self._switch_request is None:
                self._switch_request = (session.task_name, session.optimizer_name)
            self._rebuild_requested = True

    def switch_optimizer(self, optimizer: str) -> None:
        """Use the registered optimizer `optimizer` from the next cycle, keeping the plant running."""
        lookup_optimizer(optimizer)
        with self._lock:
            task = self._switch_request[0] if self._switch_request else self._session.task_name
            self._switch_request = (task, optimizer)

    def report(self, message: str, level: Literal["info", "warning", "error"] = "info") -> None:
        """Show `message` on the status line and write it to the log (each message at most once every
        few seconds, however the messages alternate)."""
        self._status_line.report(message, level)
