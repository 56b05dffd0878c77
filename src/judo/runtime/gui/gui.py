"""The browser GUI of an App: a viser server whose panel and scene follow the app's session.

`update()` is called by the app's GUI loop about 30 times a second, on the event-loop thread; the
widgets' callbacks run on viser's threads. The GUI knows the app only through the command port
(`judo.runtime.command_port.AppPort`): it reads status, calls commands and subscribes to news
(readings, plans, config edits, resets, switches), whose callbacks run on the app's threads and keep
the newest of each (`gui.news.Latest`) for `update()` to draw.
"""

import time
from typing import Any

import numpy as np
import viser

from judo.core.configuration.config import Config
from judo.core.errors import JudoError
from judo.core.reading import SystemState
from judo.core.rollouts.dynamics import drawn_model, drawn_qpos
from judo.runtime.command_port import AppPort
from judo.runtime.gui.camera import Follower, PageCameras, focus_body_id
from judo.runtime.gui.config_panel import ConfigPanel
from judo.runtime.gui.controls import Controls
from judo.runtime.gui.goal_handles import GoalHandles
from judo.runtime.gui.news import Latest
from judo.runtime.gui.plots import Plots, estimation_error
from judo.runtime.gui.safety_panel import SafetyPanel
from judo.runtime.gui.scene import SceneView
from judo.runtime.gui.server import gui_url, start_server
from judo.runtime.gui.session_panels import config_panels, estimator_panel
from judo.runtime.gui.viser_internals import purge_removed
from judo.runtime.snapshots import PlanSnapshot, Snapshot, SystemSnapshot

PLOT_PERIOD = 0.25
"""Seconds between points on the plots and updates of the numeric readout."""


class Gui:
    """Serves the GUI of `app` at http://host:port (http://host:port/TOKEN with a token) until
    `close()`.

    Raises GuiStartError (or ConfigError for a port out of range) if the server cannot start; see
    `start_server` for who may connect and the share button.
    """

    def __init__(
        self, app: AppPort, host: str, port: int, *, token: str | None = None, share: bool = False
    ) -> None:
        self.app = app
        self.token = token
        self.server = start_server(host, port, token=token, share=share, label="judo")
        self.server.scene.set_up_direction("+z")
        self.server.gui.configure_theme(
            control_width="large", dark_mode=False, show_share_button=share
        )
        # the panel beside the 3-D view, not over the robot it frames
        self.server.gui.main_panel.dock_right()
        self.controls = Controls(self.server.gui, app, order=0)
        self.plots = Plots(self.server.gui, order=100)
        self.panels: dict[str, ConfigPanel] = {}
        self.scene: SceneView | None = None
        # the estimate, while an estimator runs on the app's simulation
        self.ghost: SceneView | None = None
        self.estimator_panel: ConfigPanel | None = None
        self.safety_panel: SafetyPanel | None = None  # the limits in force, read-only
        self.follower: Follower | None = None
        self.goals: GoalHandles | None = None
        self.cameras = PageCameras(self.server)  # every page's camera: framed, then following
        self._scene_task: str | None = None
        self._generation = -1  # the session the panels and scene show
        # plant resets the app has said it carried out: a plan stamped with fewer is stale
        self._resets = 0
        # the reading shown
        self._shown: Snapshot[SystemSnapshot] | None = app.buffer.latest("system")
        # a session to build the panels and scene for
        self._session: Latest[Any] = Latest(app.session)
        # a reading not yet drawn
        self._state: Latest[Snapshot[SystemSnapshot]] = Latest(self._shown)
        self._plan: Latest[Snapshot[PlanSnapshot]] = Latest()  # a plan not yet drawn
        # a config edit made outside the panels: show it in them
        self._edited: Latest[bool] = Latest()
        # a task config edit: move the markers and goal handles
        self._task_edited: Latest[bool] = Latest()
        # the plant was reset: frame it again with its next reading
        self._reset: Latest[bool] = Latest()
        app.on_session(self._session.put)
        app.on_state(self._state.put)
        app.on_plan(self._plan.put)
        app.on_config_change(self._config_changed)
        app.on_reset(self._plant_reset)
        self._start = self._last_plot = time.perf_counter()
        self.server.on_client_connect(self._frame_new_page)

    def _config_changed(self, kind: str, config: Config, from_gui: bool) -> None:
        if not from_gui:
            self._edited.put(True)
        if kind == "task":
            self._task_edited.put(True)

    def _plant_reset(self, resets: int) -> None:
        self._resets = resets
        self._reset.put(True)

    @property
    def url(self) -> str:
        """Where a browser finds the GUI."""
        return gui_url(self.server, self.token)

    @property
    def shown_generation(self) -> int:
        """The generation of the session the panels and scene were last built for (-1 before the
        first)."""
        return self._generation

    def camera_sent(self, client_id: int) -> tuple[np.ndarray, np.ndarray] | None:
        """(position (3,), look_at (3,)) of the camera last sent to page `client_id` (None before
        any): what the page shows with the bodies posed in the same update, however late it reports
        back."""
        return self.cameras.sent(client_id)

    def update(self) -> None:
        """Follow the app: rebuild after a switch, refresh widgets, pose the scene, draw traces and
        plots.

        The status line and the pause button are refreshed whatever happens to the rest of the frame
        (a frame skipped while a switch is under way, or one that fails), so a page never shows a
        stale status."""
        try:
            self._update()
        finally:
            self.controls.update()

    def _update(self) -> None:
        session = self._session.take()
        if session is not None and not self._build_for(session):
            self._session.restore(session)  # its plant has not published its first reading yet
            return
        if self._generation < 0:
            return
        app = self.app
        assert self.scene is not None and self._shown is not None
        # a script's edit, Reset configs, a switch: the panels show the configs in force
        if self._edited.take():
            configs = app.configs()
            # these configs may be the next session's: it rebuilds the panels
            if self._session.waiting():
                return
            redraw, self.controls.redraw_requested = self.controls.redraw_requested, False
            for kind, config in configs.items():
                self.panels[kind].show(config, redraw=redraw)
            estimator = app.session.closed_loop.estimator
            if self.estimator_panel is not None and estimator is not None:
                self.estimator_panel.show(estimator.config, redraw=redraw)
        state = self._state.take()
        if state is not None and state.value.generation != self._generation:
            state = None  # a reading of the session before
        task_edited = self._task_edited.take()
        if task_edited:
            self.scene.set_markers(app.configs()["task"])
        if state is not None:
            self._draw_state(state)
        if self.goals is not None and (state is not None or task_edited):
            metadata = self._shown.value.reading.metadata
            self.goals.update(
                app.configs()["task"], metadata.get("mocap_pos"), metadata.get("mocap_quat")
            )
        plan = self._plan.take()
        if (
            plan is not None
            and plan.value.generation == self._generation
            and plan.value.resets == self._resets
        ):
            # never a plan of the plant before a reset
            self.scene.set_traces(plan.value.traces, anchored=True)
        now = time.perf_counter()
        if now - self._last_plot >= PLOT_PERIOD:
            self._last_plot = now
            figures = app.stats.live()
            self.plots.add(now - self._start, figures)
            shown = self._shown.value
            if shown.true_state is not None:
                errors = estimation_error(
                    app.session.controller.task.model, shown.true_state, shown.reading.state
                )
                self.plots.add_estimation(now - self._start, *errors)
            self.controls.show_readout(shown.reading.time, figures, shown.reading.metadata)
        for panel in self.panels.values():
            panel.flush()
        if self.estimator_panel is not None:
            self.estimator_panel.flush()

    def _build_for(self, session: Any) -> bool:
        """Build the panels and scene for `session` from its plant's first reading; False until
        there is one."""
        state = self._state.take()
        if state is not None and state.value.generation != session.generation:
            state = None  # the plant before the switch
        if state is None:
            return False
        self._shown = state
        if not self._rebuild(session, state.value.reading):
            self._state.restore(state)
            return False
        return True

    def _draw_state(self, state: Snapshot[SystemSnapshot]) -> None:
        """Pose the scene (and the estimate's ghost) at `state`, and move the cameras with it."""
        assert self.scene is not None
        self._shown = state
        reading, truth = state.value.reading, state.value.true_state
        task = self.app.session.controller.task
        with self.server.atomic():
            self.scene.update(
                drawn_qpos(task, reading.state if truth is None else truth), reading.metadata
            )
            if self.ghost is not None and truth is not None:
                self.ghost.update(drawn_qpos(task, reading.state), reading.metadata)
        if self._reset.take():  # the plant is back at its start: frame it again
            self.frame_task()
        else:
            self._follow()

    def close(self) -> None:
        """Stop the server."""
        self.server.stop()

    def _rebuild(self, session: Any, reading: SystemState) -> bool:
        """New config panels for `session`, and for a new task a new scene whose camera frames the
        plant's `reading`; False (nothing changed) if another session replaced it meanwhile."""
        app = self.app
        configs = app.configs()
        # the configs read may be of the session after it
        if app.session is not session or self._session.waiting():
            return False
        self._edited.take()  # the panels are built from these configs
        self._task_edited.take()
        for panel in [
            *self.panels.values(),
            *([self.estimator_panel] if self.estimator_panel else []),
        ]:
            panel.remove()
        self.panels, self.estimator_panel = {}, None
        # a new model; a new optimizer keeps scene and camera
        if session.task_name != self._scene_task:
            # until the new scene is built: a frame that fails here builds it again
            self._scene_task = None
            if self.scene is not None:
                self.scene.remove()
                self.scene = None
            if self.goals is not None:
                self.goals.remove()
                self.goals = None
            if self.ghost is not None:
                self.ghost.remove()
                self.ghost = None
            task = session.controller.task
            # the planning model, or a task with its own dynamics' drawing model
            model = drawn_model(task)
            self.scene = SceneView(self.server.scene, model)
            self.scene.update(drawn_qpos(task, reading.state), reading.metadata)
            self.scene.set_markers(configs["task"])
            self.goals = GoalHandles(
                self.server.scene,
                model,
                configs["task"],
                self._drag_field(session.generation),
                self._drag_mocap,
            )
            self.follower = Follower(model, focus_body_id(model, type(task).focus_body))
            self.frame_task()
            self._scene_task = session.task_name
        assert self.scene is not None
        self.scene.set_markers(configs["task"])
        # a new optimizer: the old one's plan and figures go
        self.scene.set_traces(np.zeros((0, 0, 0, 3)))
        self.plots.clear()
        self.panels = config_panels(self.server.gui, app, session, configs)
        self._show_estimator(session, reading)
        if self.safety_panel is not None:
            self.safety_panel.remove()
        guard = session.closed_loop.guard  # the [safety] limits' serve filter, or None
        self.safety_panel = SafetyPanel(
            self.server.gui, None if guard is None else guard.limits, 45
        )
        self.controls.show_session()
        self._generation = session.generation
        # viser keeps every removed widget's and scene node's tombstone for clients that connect
        # later, and purges them only when one does: purge now, or each switch would grow the app's
        # memory.
        purge_removed(self.server)
        return True

    def _show_estimator(self, session: Any, reading: SystemState) -> None:
        """The estimator's config panel, and while it runs on the app's own simulation (the
        snapshots carry the true state) the estimate's ghost and the estimation-error chart."""
        estimator = session.closed_loop.estimator
        simulated = estimator is not None and session.simulated is not None
        if simulated and self.ghost is None:
            self.ghost = SceneView(
                self.server.scene, drawn_model(session.controller.task), "/ghost", ghost=True
            )
            self.ghost.update(drawn_qpos(session.controller.task, reading.state), reading.metadata)
        elif not simulated and self.ghost is not None:
            self.ghost.remove()
            self.ghost = None
        self.plots.show_estimation(simulated)
        self.estimator_panel = estimator_panel(self.server.gui, self.app, session)

    def frame_task(self) -> None:
        """Point every page's camera (and a new page's) at the task as the scene shows it now, and
        clear the traces and plots of what ran before."""
        assert self.scene is not None and self.follower is not None
        self.scene.set_traces(np.zeros((0, 0, 0, 3)))
        self.plots.clear()
        self.cameras.frame(*self.scene.camera_pose())
        self.follower.restart(self.scene.data)

    def _frame_new_page(self, client: viser.ClientHandle) -> None:
        """A page opened mid-run looks at the task where it is now, not where it started."""
        if self.scene is not None:
            self.cameras.frame_page(client, *self.scene.camera_pose())

    def _follow(self) -> None:
        """Move every camera by how far the focus body moved, while "follow" is on (see
        `PageCameras.follow`)."""
        assert self.scene is not None and self.follower is not None
        delta = self.follower.step(self.scene.data)
        if self.follower.body:
            self.scene.keep_floor_under(self.scene.data.xpos[self.follower.body])
        self.cameras.move(delta)
        if self.controls.follow.value and np.any(np.abs(delta) > 1e-6):
            self.cameras.follow(self.scene.goal_positions())

    def _drag_field(self, generation: int) -> Any:
        def drag(name: str, value: np.ndarray) -> None:
            try:
                # the sliders follow
                self.app.commands.update_config("task", {name: value}, generation=generation)
            except JudoError as err:
                self.app.report(f"goal not moved: {err}", "warning")

        return drag

    def _drag_mocap(self, index: int, position: np.ndarray, wxyz: np.ndarray) -> None:
        try:
            self.app.commands.move_goal(index, position, wxyz)
        except JudoError as err:
            self.app.report(f"goal not moved: {err}", "warning")
