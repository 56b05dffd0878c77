"""The judo app: a plant thread, a planner and a browser GUI side by side, sharing one
lock-protected state.

    app = judo.App(task="cartpole", optimizer="mppi")   # GUI at http://127.0.0.1:8080
    app.start(); app.commands.update_config("optimizer", {"sigma": 0.2}); app.stop(); print(app.summary())

The App checks its run settings (`judo.runtime.commands.check_app_settings`: a bad one is a one-line
ConfigError before anything is built), then composes parts that own their state and are handed what
they use (docs/architecture.md): `AppState` (the configs in force and pending, the requests, pause,
the counters), `Commands` (each command validated and queued: `app.commands.update_config(...)`,
`.pause()`, `.switch_task(...)`), `PlantRunner` (the System's thread), `PlannerRunner` (the control
clock, planning and switches), `Supervisor` (the event loop, signals, the monitor and the stop
order), `Recordings`, and the frontend (the GUI, given to the App, which never imports it).
The App implements the GUI's command port (`judo.runtime.command_port.AppPort`); `start()` returns
at once. What the app publishes arrives by callback, on the thread that made it (keep a callback
cheap): `on_state` each plant reading, `on_plan` each plan, `on_config_change` each accepted config,
`on_reset` each plant reset, `on_session` each switch, `on_recording` each recording begun or ended,
`on_status` each status line.

A stop (`stop()`, Ctrl-C, SIGTERM) takes effect within about a second whatever the configs: every
wait is cut short, planning stops between optimizer iterations, and a call stuck in a rollout is
left to its daemon thread.
"""  # noqa: E501

import asyncio
import functools
import logging
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from judo.core.configuration.config import Config
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import ConfigKind
from judo.core.errors import JudoError
from judo.core.estimator import EstimatorConfig
from judo.core.optimizer import OptimizerConfig
from judo.core.planner import Planner
from judo.core.planner_view import PlannerKind
from judo.core.policies.policy_controller import as_policy
from judo.core.policy import Policy
from judo.core.task import TaskConfig
from judo.evaluation.sensing import Observe, Sensing
from judo.loop.sensing import PerType
from judo.loop.system import System, missing_halt
from judo.recording.live import LiveRecorder, RecorderFactory
from judo.runtime.address import check_port, check_token
from judo.runtime.app_state import AppState
from judo.runtime.commands import Commands, check_app_settings
from judo.runtime.exchange import RunStats, StateBuffer
from judo.runtime.live_recording import Recordings
from judo.runtime.running.planner import PlannerRunner
from judo.runtime.running.plant import PlantRunner
from judo.runtime.running.supervisor import (
    FrontendFactory,
    Supervisor,
    stop_at_exit,
    viser_frontend,
)
from judo.runtime.session import Session, SessionMaker
from judo.runtime.snapshots import CycleCost, PlanSnapshot, RunSummary, Snapshot, SystemSnapshot
from judo.runtime.status import Level, Reports, Status, StatusLine
from judo.safety.stop import StopLatch, default_stop_file

__all__ = ["App"]

logger = logging.getLogger("judo.app")


class App:
    """Runs a task and optimizer in real time, with a browser GUI unless `gui=False`.

    Args:
        task, optimizer: registry names (UnknownNameError lists the valid ones).
        controller_config, optimizer_config, task_config: start configs; the task's registered
            defaults where left out.
        system: the plant to drive, e.g. your hardware; a MuJoCo simulation of the task by default.
            A user system stays for the whole run, so switching task is refused.
        gui: serve the viser GUI at http://host:port (http://host:port/TOKEN with a token); or a
            function that builds another frontend from the App (the `AppPort`,
            `judo.runtime.command_port`) on the app's event loop, anything with `url`, `update()`
            (one frame, about 30 Hz) and `close()`.
        host: address the GUI listens on; 127.0.0.1 (this machine only) by default. Any other
            address (0.0.0.0: every interface) exposes the app to the network: a warning is logged
            and a token is required.
        port: the GUI's TCP port, 0..65535; the next free one if it is taken.
        token: secret the GUI's URL must carry (see docs/gui.md); generated when `host` is not a
            loopback address.
        share: show viser's share button (a public URL through share.viser.studio); off by default,
            and clients' share requests are refused.
        duration: stop after this many seconds of sim time; None runs until `stop()`.
        seed: seeds the optimizer, the task and the simulated plant.
        num_workers: rollout threads; the number of cores by default.
        backend: rollout backend, "cpu" (threads) or "warp" (MuJoCo Warp, a GPU when there is one).
        system_call_limit: seconds a call into the System (read_state, apply, step, reset) may block
            before the status line reports it and the robot is halted (`System.halt`) where the
            System offers it.
        estimator, estimator_config: the registered estimator between the plant's readings and the
            plan, and its config (its registered defaults where left out). By default none for a
            full-state reading, and the task's `default_estimator` ("ekf"; "ukf" for walker and
            leap_cube) for one with only measured sensors (observe="sensors", or a System whose
            reading has state None), chosen again for each task switched to. Edit its config live
            with `update_estimator_config`.
        observe: "state" (the simulated plant's full state) or "sensors" (only the task's measured
            sensors, through `judo.loop.sensing.SensedSystem`: rehearsed sensing, its noise seeded
            from `seed`).
        sensor_noise, sensor_delay, sensor_rate: the rehearsed sensors' noise std, delay (s) and
            rate (Hz), one value for all or {sensor type: value} with an optional "default"; used
            with observe="sensors".
        proposal_policy: a `judo.Policy`, or an ONNX file (needs the `policy` extra), whose
            candidates replace `controller_config.policy_samples` of the rollouts each update
            (docs/policies.md), in sessions of `task` (a switch to another task plans without it).
            PolicyError at once if it does not fit the task.
        policy: a `judo.Policy`, or an ONNX file (the `policy` extra), that drives the plant instead
            of `optimizer` through the same closed loop (docs/policies.md): the session's optimizer
            is then "policy", and its controller config the policy's metadata's rate and chunk
            layout (where `controller_config` is None). `switch_optimizer(name)` hands the plant to
            MPC, `switch_optimizer("policy")` back; another task: MPC.
        recorder_factory: makes the recorder of `start_recording(path)`; None writes collect's HDF5
            layout (`judo.recording.live`, needs the `collect` extra).
        stop_file: the latched stop's state file (`judo.safety.stop`, the app's `stop_latch`); None:
            the default one.

    Raises UnknownNameError or ConfigError at once for bad names or configs.
    """

    def __init__(
        self,
        task: str = "cartpole",
        optimizer: str = "mppi",
        *,
        controller_config: ControllerConfig | None = None,
        optimizer_config: OptimizerConfig | None = None,
        task_config: TaskConfig | None = None,
        system: System | None = None,
        gui: bool | FrontendFactory = True,
        host: str = "127.0.0.1",
        port: int = 8080,
        token: str | None = None,
        share: bool = False,
        duration: float | None = None,
        seed: int | None = None,
        num_workers: int | None = None,
        backend: str = "cpu",
        system_call_limit: float = 0.5,
        estimator: str | None = None,
        estimator_config: EstimatorConfig | None = None,
        observe: Observe = "state",
        sensor_noise: PerType = None,
        sensor_delay: PerType = None,
        sensor_rate: PerType = None,
        recorder_factory: RecorderFactory | None = None,
        proposal_policy: Policy | str | Path | None = None,
        policy: Policy | str | Path | None = None,
        stop_file: str | Path | None = None,
    ) -> None:
        check_app_settings(duration, num_workers, seed, system_call_limit, system, observe)
        self.gui_enabled, self.host, self.port = gui is not False, host, check_port(port)
        self.duration, self.token = duration, check_token(token, host, generate=gui is not False)
        self.share, self.backend, self.system_call_limit = share, backend, system_call_limit
        self.buffer = StateBuffer()  # the GUI's view: the latest reading and plan
        self.stats = RunStats()
        self._state = state = AppState(
            Sensing(observe, sensor_noise, sensor_delay, sensor_rate, estimator, estimator_config)
        )
        self._reports = reports = Reports(line=StatusLine(), state=state)
        latch_file = default_stop_file() if stop_file is None else stop_file
        self.stop_latch = StopLatch(latch_file, reports.on_stop)
        if system is not None and (warning := missing_halt(system)) is not None:
            reports.report(warning, "warning")
        maker = SessionMaker(
            user_system=system,
            seed=seed,
            num_workers=num_workers,
            backend=backend,
            clock=None if system is None else state.clock,  # a robot's plans age in wall time
            on_watchdog=reports.on_watchdog,
            proposal_policy=None if proposal_policy is None else as_policy(proposal_policy),
            proposal_task=task,
            policy=None if policy is None else as_policy(policy),
            policy_task=task,
            fallback_optimizer=optimizer,
            stop=self.stop_latch,
        )
        first = optimizer if maker.policy is None else PlannerKind.POLICY.value
        session = maker.first(
            task, first, state.sensing, controller_config, optimizer_config, task_config
        )
        state.begin(session)
        self._policy_name = None if maker.policy is None else maker.policy.name
        self.commands = Commands(state=state, reports=reports, maker=maker)  # app.commands.pause()
        self._recordings = Recordings(state=state, reports=reports, factory=recorder_factory)
        make_frontend: Callable[[], Any] | None = None
        if gui is not False:
            make_frontend = functools.partial(gui, self) if callable(gui) else viser_frontend(self)
        self._supervisor = Supervisor(
            state=state,
            plant=PlantRunner(
                state=state,
                buffer=self.buffer,
                stats=self.stats,
                reports=reports,
                duration=duration,
                request_stop=state.stop.set,
            ),
            planner=PlannerRunner(
                state=state,
                maker=maker,
                buffer=self.buffer,
                stats=self.stats,
                reports=reports,
                recordings=self._recordings,
            ),
            recordings=self._recordings,
            reports=reports,
            system_call_limit=system_call_limit,
            make_frontend=make_frontend,
            stop_latch=self.stop_latch,
        )
        self._thread: threading.Thread | None = None
        self._ran = False

    # ---- lifecycle -------------------------------------------------------------------------
    def start(self) -> None:
        """Run the loops in a background thread and return once they (and the GUI server) are up.

        Raises GuiStartError (or ConfigError) if the GUI server cannot start."""
        self._claim_run()
        self._thread = threading.Thread(target=self._run_in_thread, name="judo-app", daemon=True)
        self._thread.start()
        self._supervisor.ready.wait()
        if self._supervisor.start_error is not None:
            self._thread.join()
            raise self._supervisor.start_error
        stop_at_exit(self)  # stopped at interpreter exit if the script never calls stop()

    def run(self) -> RunSummary:
        """Run the loops in this thread until `duration` is reached, `stop()`, Ctrl-C or SIGTERM.

        Raises GuiStartError (or ConfigError) if the GUI server cannot start."""
        self._claim_run()
        on_main_thread = threading.current_thread() is threading.main_thread()
        asyncio.run(self._supervisor.main(handle_signals=on_main_thread))
        return self.summary()

    def stop(self, timeout: float | None = 10.0) -> None:
        """Ask every loop to finish, and wait for them (when started with `start()`), at most
        `timeout` s.

        Takes effect within about a second: a planning cycle in flight is abandoned to its
        thread."""
        self._state.stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the app stops by itself (its `duration` reached); True if it did within
        `timeout`."""
        if self._thread is None:
            return self._state.stop.is_set()
        self._thread.join(timeout)
        return not self._thread.is_alive()

    @property
    def running(self) -> bool:
        """True from `start()`/`run()` until the loops have finished."""
        return self._ran and not self._supervisor.finished.is_set()

    def summary(self) -> RunSummary:
        """Control rate, plan times, real-time factor and final reward of the run so far."""
        session = self._state.session
        guard = session.closed_loop.guard  # the [safety] limits' serve filter, or None
        return self.stats.summary(
            session.task_name, session.optimizer_name, self.stop_latch, guard and guard.summary()
        )

    def _claim_run(self) -> None:
        if self._ran:
            raise JudoError("this App has already run; create a new App to run again")
        self._ran = True

    def _run_in_thread(self) -> None:
        try:
            asyncio.run(self._supervisor.main())
        except BaseException as err:  # before the loops started, start() raises it; later, log it
            if err is not self._supervisor.start_error:
                logger.error("the judo app failed", exc_info=err)

    # ---- what the GUI and scripts read ---------------------------------------------------------
    @property
    def gui(self) -> Any:
        """The GUI (`judo.runtime.gui.gui.Gui`, or the frontend given) while the app runs with one,
        else None."""
        return self._supervisor.frontend

    @property
    def policy_name(self) -> str | None:
        """The policy the app can serve as its controller (the optimizer dropdown's "policy"), or
        None."""
        return self._policy_name

    @property
    def session(self) -> Session:
        """The session in use: names, controller and plant. Replaced, never changed, on a switch."""
        return self._state.session

    @property
    def controller(self) -> Planner:
        """The controller in use; its configs change only at the top of a planning cycle."""
        return self._state.session.controller

    @property
    def paused(self) -> bool:
        """True while the plant and the planner are paused."""
        return self._state.paused

    @property
    def status(self) -> Status:
        """The latest status message."""
        return self._reports.status

    @property
    def resets_done(self) -> int:
        """Task resets the plant has carried out so far."""
        return self._state.resets_done

    def configs(self) -> dict[ConfigKind, Config]:
        """The latest accepted config of each kind; a planning cycle may not have picked them up
        yet."""
        return self._state.configs.as_dict()

    def planning_cost(self) -> CycleCost:
        """The cycle's size (N x R x iterations x T; None where a policy drives) and estimated
        seconds under the latest configs, the last update's seconds, and the late cycle's seconds so
        far (else None); judo.runtime.exchange."""
        return self._state.planning_cost()

    # ---- news by callback, on the thread that made it: a callback keeps the value and returns at o
    def on_state(self, callback: Callable[[Snapshot[SystemSnapshot]], None]) -> None:
        """Call `callback(snapshot)` with each plant reading published (`app.buffer`'s "system"), on
        the plant's thread."""
        self.buffer.subscribe("system", callback)

    def on_plan(self, callback: Callable[[Snapshot[PlanSnapshot]], None]) -> None:
        """Call `callback(snapshot)` with each plan published (`app.buffer`'s "plan"), on the
        planner's thread."""
        self.buffer.subscribe("plan", callback)

    def on_config_change(self, callback: Callable[[str, Config, bool], None]) -> None:
        """Call `callback(kind, config, from_gui)` with each config accepted ("controller",
        "optimizer", "task" or "estimator"; `from_gui` for the GUI's own panel edits), on the thread
        of the command."""
        self._state.config_changed.add(callback)

    def on_reset(self, callback: Callable[[int], None]) -> None:
        """Call `callback(resets_done)` after each reset the plant carried out, on the plant's
        thread."""
        self._state.plant_reset.add(callback)

    def on_session(self, callback: Callable[[Session], None]) -> None:
        """Call `callback(session)` once a switch installed the new session, on the planner's
        thread."""
        self._state.session_changed.add(callback)

    def on_recording(self, callback: Callable[[Path | None], None]) -> None:
        """Call `callback(path)` when a recording begins (its file) or ends (None)."""
        self._recordings.on_change(callback)

    def on_status(self, callback: Callable[[Status], None]) -> None:
        """Call `callback(status)` with each new status line, on the thread that reported it."""
        self._reports.line.changed.add(callback)

    def report(self, message: str, level: Level = "info") -> None:
        """Show `message` on the status line and write it to the log (each message at most every few
        seconds)."""
        self._reports.report(message, level)

    @property
    def recording(self) -> Path | None:
        """The file a recording under way will be written to, or None."""
        return self._recordings.path

    def start_recording(self, recorder: LiveRecorder | str | Path | None = None) -> Path:
        """Record every step, plan and config edit until `stop_recording()` (or a switch) with
        `recorder` (a LiveRecorder of `app.session`), or into a path by the recorder factory
        (collect's layout by default). Returns its file."""
        return self._recordings.start(recorder)

    def stop_recording(self) -> Path | None:
        """Write the recording under way as its file's next demo (for replay); its file, or None;
        JudoError on failure."""
        return self._recordings.stop()
