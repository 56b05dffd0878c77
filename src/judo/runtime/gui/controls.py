"""The top of the GUI panel: task and optimizer dropdowns, the latched stop, pause/resume, reset
buttons and the status line.

Every control only calls a command of the app's port (`judo.runtime.command_port.AppPort`); the
app's loops carry it out at their next iteration. The status line follows the app's `on_status` news
(a pause, a resume and each change of the latched stop are reported on it), the record box its
`on_recording` news.
"""

import math

import numpy as np
import viser

from judo.core.configuration.registry import (
    get_registered_estimators,
    get_registered_optimizers,
    get_registered_tasks,
)
from judo.core.errors import JudoError
from judo.core.planner_view import PlannerKind
from judo.runtime.command_port import AppPort
from judo.runtime.gui.news import Latest
from judo.runtime.snapshots import LiveFigures
from judo.runtime.status import Status

MARKDOWN_SPECIAL = set("\\`*_[]<>#|")
NO_ESTIMATOR = "none"
"""The estimator dropdown's entry for planning from full-state readings as they are."""
INFERENCE_WINDOW = 100
"""Latest updates whose median the readout shows as a policy's inference time."""
STATUS_PREFIX = {"info": "", "warning": "warning: ", "error": "error: "}
STOP_KEY = "escape"
"""The key that latches the stop, from anywhere on the page (a command of viser's command
palette)."""


class Controls:
    """Dropdowns of the registered tasks and optimizers, three buttons and a status line."""

    def __init__(self, gui: viser.GuiApi, app: AppPort, order: float) -> None:
        self.app = app
        session = app.session
        self.task = gui.add_dropdown(
            "task",
            sorted(get_registered_tasks()),
            initial_value=session.task_name,
            order=order,
            hint="Registered tasks",
        )
        self.optimizer = gui.add_dropdown(
            "optimizer",
            sorted(get_registered_optimizers())
            + ([PlannerKind.POLICY.value] if app.policy_name else []),
            initial_value=session.optimizer_name,
            order=order + 0.1,
            hint="Registered optimizers"
            + (f"; policy: {app.policy_name} drives the plant" if app.policy_name else ""),
        )
        self.estimator = gui.add_dropdown(
            "estimator",
            [NO_ESTIMATOR, *sorted(get_registered_estimators())],
            initial_value=session.estimator_name or NO_ESTIMATOR,
            order=order + 0.15,
            hint="Registered estimators, between the plant's readings and the plan (none: plan "
            "from the full state)",
        )
        self.stop = gui.add_button(
            "Stop",
            color="red",
            order=order + 0.18,
            hint=f"Latch the stop ({STOP_KEY.capitalize()} key): the safe action (or the robot's "
            "halt) until Clear stop",
        )
        self.clear_stop = gui.add_button(
            "Clear stop",
            disabled=True,
            order=order + 0.19,
            hint="Clear the latched stop: the plan is served again",
        )
        self.stop_key = gui.add_command(
            "Stop (latched)", description="Latch the stop", hotkey=STOP_KEY
        )
        self.stop.on_click(lambda _: app.stop_latch.engage("the GUI's Stop button"))
        self.clear_stop.on_click(lambda _: app.stop_latch.clear("the GUI's Clear stop button"))
        self.stop_key.on_trigger(
            lambda _: app.stop_latch.engage(f"the GUI's {STOP_KEY.capitalize()} key")
        )
        self.pause = gui.add_button(
            "Pause", order=order + 0.2, hint="Pause or resume the plant and the planner"
        )
        self.reset_task = gui.add_button(
            "Reset task", order=order + 0.3, hint="Put the plant in its start state"
        )
        self.reset_configs = gui.add_button(
            "Reset configs", order=order + 0.4, hint="Put every config back to the task's defaults"
        )
        self.follow = gui.add_checkbox(
            "follow camera",
            True,
            order=order + 0.45,
            hint="Keep the task's focus body in view while it runs",
        )
        self.record = gui.add_checkbox(
            "record",
            False,
            order=order + 0.47,
            hint="Record every step, plan and config edit to judo-recording-TASK-TIME.h5 (needs "
            "judo-mpc[collect]); "
            "untick to write it, then: python -m judo replay FILE",
        )
        self.record.on_update(lambda event: self._toggle_recording(event))
        self.status = gui.add_markdown("", order=order + 0.5)
        self.readout = gui.add_markdown("", order=order + 0.6)
        self.cost = gui.add_markdown("", order=order + 0.65)
        # the task's own line (`Task.readout`)
        self.task_readout = gui.add_markdown("", order=order + 0.67)
        self._status: Latest[Status] = Latest(app.status)  # a status line not yet shown
        # a recording began or ended: tick or untick the box
        self._recording: Latest[bool] = Latest()
        app.on_status(self._status.put)
        app.on_recording(lambda _path: self._recording.put(True))
        self.task.on_update(
            lambda event: self._switch(event, app.commands.switch_task, self.task, "task")
        )
        self.optimizer.on_update(
            lambda event: self._switch(
                event, app.commands.switch_optimizer, self.optimizer, "optimizer"
            )
        )
        self.estimator.on_update(
            lambda event: self._switch(
                event,
                lambda name: app.commands.switch_estimator(None if name == NO_ESTIMATOR else name),
                self.estimator,
                "estimator",
            )
        )
        self.pause.on_click(lambda _: app.commands.resume() if app.paused else app.commands.pause())
        self.reset_task.on_click(lambda _: app.commands.reset_task())
        self.redraw_requested = False  # set by Reset configs: every page redraws every widget
        self.reset_configs.on_click(lambda _: self._reset_configs())

    def update(self) -> None:
        """Show a recording begun or ended, and a new status line with the pause state and the
        latched stop."""
        if self._recording.take():
            self.show_recording()
        if self._status.take() is None:
            return
        paused, latched = self.app.paused, self.app.stop_latch.latched
        self.pause.label = "Resume" if paused else "Pause"
        self.stop.label, self.stop.disabled, self.clear_stop.disabled = (
            ("STOPPED", True, False) if latched else ("Stop", False, True)
        )
        self.status.content = status_markdown(self.app.status, paused)

    def show_readout(
        self, sim_time: float, figures: LiveFigures, metadata: dict | None = None
    ) -> None:
        """Sim time, plan time, control rate and real-time factor as numbers ("-" before there is
        data), the planning cycle's cost, and the task's own line from the plant's `metadata`
        (`Task.readout`)."""

        def shown(value: float, unit: str, digits: int) -> str:
            return f"{value:.{digits}f}{unit}" if math.isfinite(value) else "-"

        session = self.app.session
        policy = self.app.policy_name if session.controller.kind is PlannerKind.POLICY else None
        if policy is None:
            update = f"plan {shown(figures.plan_time_ms, ' ms', 1)}"
        # the span `evaluate` reports: the closed loop's update (observation, `act`, plan), its
        # median
        else:
            recent = session.closed_loop.update_ms[-INFERENCE_WINDOW:]
            median = 1e3 * float(np.median(recent)) if recent else math.nan
            update = f"policy {policy} · inference {shown(median, ' µs', 0)} (median, as evaluate)"
        self.readout.content = (
            f"sim time {shown(sim_time, ' s', 1)} · {update} · "
            f"{shown(figures.control_rate, ' Hz', 1)} · real-time factor "
            f"{shown(figures.real_time_factor, '', 2)}"
        )
        self.cost.content = self.app.planning_cost().line().replace(" x ", " × ")
        line = session.controller.task.readout(metadata or {})
        self.task_readout.content = "" if line is None else markdown_text(line)

    def _toggle_recording(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        try:
            if self.record.value:
                self.app.start_recording()
            else:
                self.app.stop_recording()
        except JudoError as err:
            self.app.report(f"recording: {err}", "error")
        self.show_recording()

    def show_recording(self) -> None:
        """Tick the record box while a recording is under way: called when one starts or ends (a
        switch ends it by itself), and after a page's toggle, to show what came of it (a refused
        start unticks it).

        Between those the box is left alone: a page's toggle is applied by viser before its callback
        runs on viser's thread pool, and putting the box back to the app's state meanwhile (the GUI
        loop runs 30 times a second) made that callback read the box put back, so an untick started
        a second recording."""
        recording = self.app.recording is not None
        if self.record.value != recording:
            self.record.value = recording

    def _reset_configs(self) -> None:
        self.redraw_requested = True
        self.app.commands.reset_configs()

    def show_session(self) -> None:
        """Point the dropdowns at the session in use (after a switch, or a refused one)."""
        session = self.app.session
        self.task.value, self.optimizer.value = session.task_name, session.optimizer_name
        self.estimator.value = session.estimator_name or NO_ESTIMATOR

    def _switch(
        self, event: viser.GuiEvent, command, dropdown: viser.GuiDropdownHandle, what: str
    ) -> None:
        if event.client is None:
            return
        wanted = dropdown.value
        try:
            command(wanted)
        except JudoError as err:
            self.app.report(f"{what} not switched: {err}", "error")
        else:
            self.app.report(f"switching {what} to {wanted}...")
        # the dropdowns name what runs: the session in use until the switch is carried
        # out (`Gui._rebuild`)
        self.show_session()


def markdown_text(text: str) -> str:
    """`text` on one line, with markdown's special characters escaped."""
    return "".join("\\" + c if c in MARKDOWN_SPECIAL else c for c in text.replace("\n", " "))


def status_markdown(status: Status, paused: bool = False) -> str:
    """The status line as markdown; warnings and errors are marked as such, and a paused app says so
    first."""
    text = markdown_text(status.message)
    state = "**paused** · " if paused and status.message != "paused" else ""
    return f"**status:** {state}{STATUS_PREFIX[status.level]}{text}"
