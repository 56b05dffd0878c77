"""The app's status reports: its status line, worded with the session in use, for every part of the app."""

from judo.runtime.app_state import AppState
from judo.runtime.status_line import Level, Status, StatusLine


class Reports:
    """Reports to the app's status line (and the log) from any thread.

    Args:
        line: the status line the GUI shows.
        state: the app's state, for the names of the session in use.
    """

    def __init__(self, line: StatusLine, state: AppState) -> None:
        self.line, self._state = line, state

    @property
    def status(self) -> Status:
        """The latest status message."""
        return self.line.status

    def report(self, message: str, level: Level = "info") -> None:
        """Show `message` (each message logged at most once every few seconds)."""
        self.line.report(message, level)

    def progress(self, message: str, level: Level = "info") -> None:
        """Show `message` without writing it to the log (a count that changes every second)."""
        self.line.report(message, level, log=False)

    def failed(self, part: str, message: str, level: Level = "error") -> None:
        """`part` (e.g. "planner") failed; it stays in trouble until it recovers."""
        self.line.failed(part, message, level)

    def recovered(self, part: str, news: str) -> None:
        """`part` works again: say `news` and that the app is running, if its failure is on the status line."""
        self.line.recovered(part, f"{news}: {self.running()}")

    def running(self) -> str:
        """'running TASK with OPTIMIZER', and ', planning with a fitted model (body_mass.pole, ...)' where the
        planning model has model overrides ([model_overrides.TASK], e.g. sysid's fitted.toml)."""
        session = self._state.session
        message = f"running {session.task_name} with {session.optimizer_name}"
        fitted = session.controller.task.model_overrides
        if fitted:
            fields = ", ".join(f"{field}.{element}" for field, values in fitted.items() for element in values)
            message += f", planning with a fitted model ({fields})"
        return message

    def on_watchdog(self, reason: str | None) -> None:
        """The closed loop's watchdog tripped (`reason`) or recovered (None): say so once per episode."""
        if reason is not None:
            self.line.failed("watchdog", f"watchdog: {reason}; serving the safe action", "warning")
        elif "watchdog" in self.line.trouble:  # said even when another part's recovery came first
            self.line.trouble.discard("watchdog")
            self.report(f"fresh plans are served again: {self.running()}")
