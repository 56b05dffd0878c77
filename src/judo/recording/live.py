"""Recording a running app: what a recorder of it does, and the default one, which writes every
step, every plan and every config edit to a collect file.

`LiveRecorder` is what `App.start_recording` takes and `RecorderFactory` what makes one from a path
(the app's `recorder_factory=`); `start_live_recording` is the default factory. `LiveRecording` is a
Recorder on the app's closed loop (`judo.loop.closed_loop`), so it records exactly what `collect`
records. `finish()` writes the recording as the next `data/demo_<n>` of an HDF5 file in the collect
layout (docs/collect.md), so `python -m judo replay FILE` plays it back. Recordings of one task,
optimizer and models share a file; each demo's attrs hold the configs at its start (`env_kwargs`,
JSON) and the edits made while it ran (`config_edits`, JSON: [{time, kind, config}], where an edit
of the estimator's config or a change of estimator is kind "estimator" with its `name`). Needs the
`collect` extra (h5py).
"""

import json
import threading
import time
from pathlib import Path
from typing import Any, Protocol

import mujoco
import numpy as np

from judo.core.configuration.config import Config
from judo.core.errors import JudoError
from judo.core.task import EpisodeLog
from judo.evaluation.episode import step_reward
from judo.loop.records import PlanRecord, Recorder, StepRecord
from judo.recording.dataset import DatasetFile, import_h5py
from judo.recording.model_info import config_dict, model_sha256
from judo.recording.recorder import EpisodeRecorder


class LiveRecorder(Recorder, Protocol):
    """A recorder of a running app (`App.start_recording`), e.g. `LiveRecording`.

    The app adds it to its session's closed loop, tells it of every config edit, moves it to the
    next session on a change of estimator, and calls `finish` when the recording stops (or the task
    or optimizer is switched).

    Attributes:
        path: the file it writes.
        session: the session it records (`judo.runtime.session.Session`).
        num_steps: plant steps recorded so far.
    """

    path: Path
    session: Any
    num_steps: int

    def on_config(self, kind: str, config: Any, **details: Any) -> None:
        """A config edit (`kind` "controller", "optimizer", "task" or "estimator"), with
        `details`."""
        ...

    def move_to(self, session: Any) -> None:
        """Go on recording `session`, which replaced the recorded one (a change of estimator)."""
        ...

    def finish(self) -> tuple[Path, int]:
        """Write the recording; returns (file, index of the recording in it)."""
        ...


class RecorderFactory(Protocol):
    """Makes the app's default recorder of `session` into `path` (None: a name of its own), from
    `configs`."""

    def __call__(
        self, path: str | Path | None, session: Any, configs: dict[Any, Any]
    ) -> LiveRecorder: ...


def default_recording_path(task: str) -> Path:
    """judo-recording-TASK-YYYYmmdd-HHMMSS.h5 in the working folder."""
    return Path(f"judo-recording-{task}-{time.strftime('%Y%m%d-%H%M%S')}.h5")


def start_live_recording(
    path: str | Path | None, session: Any, configs: dict[str, Config]
) -> "LiveRecording":
    """The app's default RecorderFactory (`judo.runtime.live_recording`): a LiveRecording of
    `session` (a `judo.runtime.session.Session`) into `path` (`default_recording_path` for None),
    from the `configs` in force."""
    # the planner has no optimizer's plans to record
    if "optimizer" not in session.controller.config_kinds:
        raise JudoError(
            "the GUI's recording holds an optimizer's plans; a policy drives this session: "
            "switch to an optimizer to "
            "record, or record the policy with python -m judo collect --policy FILE.onnx"
        )
    return LiveRecording(path or default_recording_path(session.task_name), session, configs)


class LiveRecording:
    """Records a running session until `finish()`.

    Args:
        path: the HDF5 file to add the recording to (created when missing; an existing file must
            hold recordings of the same task, optimizer and models).
        session: the app's session being recorded.
        configs: the configs in force when the recording starts, by kind.
    """

    def __init__(self, path: str | Path, session: Any, configs: dict[str, Config]) -> None:
        import_h5py("recording from the GUI")
        self.path, self.session = Path(path), session
        task = session.controller.task
        # the GUI's record keeps traces
        self._steps = EpisodeRecorder.for_loop(session.controller, task, traces=True)
        self.wants_traces = True
        self._lock = threading.Lock()
        self.config_edits: list[dict[str, Any]] = []
        # at the start
        self.env_kwargs = {kind: config_dict(config) for kind, config in configs.items()}
        self.env_args = {
            "env_name": session.task_name,
            "type": "judo",
            "source": "gui recording",
            "task": session.task_name,
            "optimizer": session.optimizer_name,
            "plant_timestep": float(session.system.timestep),
            "mujoco_version": mujoco.__version__,
            "planning_model_sha256": model_sha256(task.model),
            "plant_model_sha256": model_sha256(task.sim_model),
        }

    def on_plan(self, record: PlanRecord) -> None:
        """Keep the control update (called on the planning thread)."""
        with self._lock:
            self._steps.on_plan(record)

    def on_step(self, record: StepRecord) -> None:
        """Keep the plant step (called on the plant thread); a step without a full state is
        skipped."""
        if record.state is None:
            return
        with self._lock:
            self._steps.on_step(record)

    def on_config(self, kind: str, config: Config | None, **details: Any) -> None:
        """Keep a config edit (`kind` "controller", "optimizer", "task" or "estimator"; `config`
        None for no estimator) with the plant time of the latest step and `details` (e.g. the
        estimator's `name`)."""
        with self._lock:
            now = self._steps.steps[-1].time if self._steps.steps else 0.0
            edit = {
                "time": now,
                "kind": kind,
                **details,
                "config": None if config is None else config_dict(config),
            }
            self.config_edits.append(edit)

    def move_to(self, session: Any) -> None:
        """Go on recording `session`, which replaced the one recorded on the same task, optimizer
        and plant (a change of estimator): the steps and plans of both are one recording, with the
        change as an "estimator" edit."""
        if self in self.session.closed_loop.recorders:
            self.session.closed_loop.recorders.remove(self)
        self.session = session
        session.closed_loop.recorders.append(self)
        estimator = session.closed_loop.estimator
        self.on_config(
            "estimator",
            None if estimator is None else estimator.config,
            name=session.estimator_name,
        )

    @property
    def num_steps(self) -> int:
        """Steps recorded so far."""
        return len(self._steps.steps)

    def finish(self) -> tuple[Path, int]:
        """Write the recording as the next demo of the file; returns (path, demo index). Raises
        DatasetError if the file cannot be written or holds another task's recordings, and JudoError
        (writing nothing) when the plant took no step while it recorded."""
        with self._lock:
            recorder = self._steps.with_records(list(self._steps.steps), list(self._steps.plans))
            steps = recorder.steps
        if not steps:
            raise JudoError(
                f"nothing was recorded (the plant took no step while recording); {self.path} not "
                "written"
            )
        task = self.session.controller.task
        log = EpisodeLog(
            times=np.array([step.time for step in steps]),
            states=np.array([step.state for step in steps], dtype=float).reshape(len(steps), -1),
            controls=np.array([step.action for step in steps], dtype=float).reshape(len(steps), -1),
            sensors=np.array([step.sensors for step in steps], dtype=float).reshape(len(steps), -1),
        )
        rewards = np.array(
            [step_reward(task, log, row, steps[row].metadata) for row in range(len(steps))]
        )
        plant = self.session.simulated
        metrics = plant.task.metrics(log) if plant is not None and steps else {}
        metrics["mean_reward"] = float(rewards.mean()) if len(rewards) else float("nan")
        dataset = DatasetFile(self.path, self.env_args)
        index = max(dataset.finished_seeds(), default=-1) + 1
        success = plant.task.success(metrics) if plant is not None else None
        dataset.write_episode(recorder.episode(index, rewards, metrics, success))
        h5py = import_h5py("recording from the GUI")
        with h5py.File(self.path, "a") as file:
            demo = file[f"data/demo_{index}"]
            demo.attrs["env_kwargs"] = json.dumps(self.env_kwargs)
            demo.attrs["config_edits"] = json.dumps(self.config_edits)
        return self.path, index
