"""Recording a running app: the recorder under way, started and stopped from any thread.

Recording is injected: `start` takes any `LiveRecorder` (`judo.recording.live`), or a path, which
the app's recorder factory turns into one. The default factory,
`judo.recording.live.start_live_recording`, writes an HDF5 file in collect's layout; it imports h5py
only when a recording starts, so an app that never records never needs the `collect` extra.
"""

from collections.abc import Callable
from pathlib import Path

from judo.core.errors import JudoError
from judo.recording.live import LiveRecorder, RecorderFactory, start_live_recording
from judo.runtime.app_state import AppState
from judo.runtime.session import Session
from judo.runtime.status import Reports


class Recordings:
    """The app's recording under way (kept in `state.recording`, which hears every config edit).

    Args:
        state: the app's state.
        reports: the status line.
        factory: makes a recorder from a path; None uses `start_live_recording`.
    """

    def __init__(
        self, *, state: AppState, reports: Reports, factory: RecorderFactory | None = None
    ) -> None:
        self._state, self._reports, self._factory = state, reports, factory

    @property
    def path(self) -> Path | None:
        """The file the recording under way will be written to, or None."""
        recording = self._state.recording
        return None if recording is None else recording.path

    def on_change(self, callback: Callable[[Path | None], None]) -> None:
        """Call `callback(path)` when a recording begins (its file) or ends (None)."""
        self._state.recording_changed.add(
            lambda recorder: callback(None if recorder is None else recorder.path)
        )

    def start(self, recorder: LiveRecorder | str | Path | None = None) -> Path:
        """Add `recorder` (or a recorder of the running session into the path given; a name of its
        own for None) to the running session's closed loop until `stop`. Returns its file. Raises
        JudoError when a recording is under way or `recorder` records another session."""
        state = self._state
        with state.lock:
            if state.recording is not None:
                raise JudoError(
                    f"already recording to {state.recording.path}; stop that recording first"
                )
            session = state.session
            if recorder is None or isinstance(recorder, str | Path):
                factory = self._factory or start_live_recording
                recorder = factory(recorder, session, state.configs.as_dict())
            elif recorder.session is not session:
                raise JudoError(
                    "the recorder records another session than the one running; make it for "
                    "app.session"
                )
            session.closed_loop.recorders.append(recorder)
            state.begin_recording(recorder)
        self._reports.report(f"recording to {recorder.path}")
        return recorder.path

    def stop(self) -> Path | None:
        """Stop the recording under way and write it; returns its file, or None when nothing was
        recording. Raises what the recorder's `finish` raised when the file cannot be written."""
        recorder = self._state.end_recording()
        if recorder is None:
            return None
        if recorder in recorder.session.closed_loop.recorders:
            recorder.session.closed_loop.recorders.remove(recorder)
        path, index = recorder.finish()
        self._reports.report(
            f"recorded {recorder.num_steps} steps to {path} as demo_{index}; replay: python "
            f"-m judo replay {path}"
        )
        return path

    def finish(self, why: str) -> None:
        """Write the recording under way, if any (on a switch or a stop), reporting a failure."""
        if self._state.recording is None:
            return
        try:
            self.stop()
        except Exception as err:
            self._reports.report(
                f"the recording ({why}) could not be written: {type(err).__name__}: {err}", "error"
            )

    def move_to(self, session: Session) -> None:
        """Go on recording into `session`, which replaced the recorded one on the same plant (a
        change of estimator); call it under `state.lock`."""
        if self._state.recording is not None:
            self._state.recording.move_to(session)
