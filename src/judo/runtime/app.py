"""The judo app: one asyncio event loop running the plant, the planner and the browser GUI side by side.

    app = judo.App(task="cartpole", optimizer="mppi")   # GUI at http://127.0.0.1:8080
    app.start()          # returns at once; the loops run in a background thread
    app.update_config("optimizer", {"sigma": 0.2})
    app.stop()
    print(app.summary())

This module is the App's lifecycle (start, run, stop) and its commands (config edits, pause, reset,
switches, goal moves), callable from any thread; `judo.runtime.loops` holds the coroutines that carry them
out, each a thin wrapper around the one closed-loop step (`judo.runtime.closed_loop`). The GUI talks to the
App only through the command port (`judo.runtime.commands`).

A stop (`stop()`, Ctrl-C, SIGTERM) takes effect within about a second whatever the configs: every
wait is cut short by it, the planning cycle stops between optimizer iterations, and a call stuck in
a rollout or a slow reward is abandoned to its daemon thread rather than waited for.
"""

import asyncio
import logging
import math
import threading

import numpy as np

from judo.core.config import Config, check_seed
from judo.core.controller import Controller, ControllerConfig
from judo.core.errors import ConfigError, JudoError
from judo.core.estimator import EstimatorConfig
from judo.core.optimizer import OptimizerConfig
from judo.core.registry import CONFIG_KINDS, ConfigKind
from judo.core.task import TaskConfig
from judo.runtime import exit_guard
from judo.runtime.address import check_port, check_token
from judo.runtime.app_commands import AppCommands
from judo.runtime.loops import session_configs
from judo.runtime.sensing import PerType
from judo.runtime.session import Observe, Sensing, Session, build_session
from judo.runtime.snapshots import PlanSnapshot, SystemSnapshot
from judo.runtime.state_buffer import StateBuffer
from judo.runtime.stats import RunStats, RunSummary
from judo.runtime.status_line import Status, StatusLine
from judo.runtime.system import System
from judo.runtime.watchdog import PausableClock

__all__ = ["CONFIG_KINDS", "App", "ConfigKind", "PlanSnapshot", "Status", "SystemSnapshot"]

logger = logging.getLogger("judo.app")

MAX_WORKERS = 1024
"""Most rollout threads an app may ask for."""


class App(AppCommands):
    """Runs a task and optimizer in real time, with a browser GUI unless `gui=False`.

    Args:
        task, optimizer: registry names (UnknownNameError lists the valid ones).
        controller_config, optimizer_config, task_config: start configs; the task's registered
            defaults where left out.
        system: the plant to drive, e.g. your hardware; a MuJoCo simulation of the task by default.
            A user system stays for the whole run, so switching task is refused.
        gui: serve the viser GUI at http://host:port (http://host:port/TOKEN with a token).
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
        system_call_limit: seconds a call into the System (read_state, apply, step, reset) may block before
            the status line reports it and the robot is halted (`System.halt`) where the System offers it.
        estimator, estimator_config: the registered estimator between the plant's readings and the plan,
            and its config (its registered defaults where left out). By default none for a full-state
            reading, and the task's `default_estimator` ("ekf"; "ukf" for walker and leap_cube) for one with
            only measured sensors (observe="sensors", or a System whose reading has state None), chosen again
            for each task switched to. Edit its config live with `update_estimator_config`.
        observe: "state" (the simulated plant's full state) or "sensors" (only the task's measured sensors,
            through `judo.runtime.sensing.SensedSystem`: rehearsed sensing, its noise seeded from `seed`).
        sensor_noise, sensor_delay, sensor_rate: the rehearsed sensors' noise std, delay (s) and rate (Hz),
            one value for all or {sensor type: value} with an optional "default"; used with observe="sensors".

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
        gui: bool = True,
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
    ) -> None:
        if duration is not None and not 0 < duration < math.inf:
            raise ConfigError(
                f"duration must be a positive, finite number of seconds of sim time (or None to run until stopped), "
                f"got {duration}"
            )
        if num_workers is not None and not (isinstance(num_workers, int) and 1 <= num_workers <= MAX_WORKERS):
            raise ConfigError(
                f"num_workers must be an integer from 1 to {MAX_WORKERS} (or None: one per core), got {num_workers!r}"
            )
        check_seed(seed)
        if not 0 < system_call_limit < math.inf:
            raise ConfigError(
                f"system_call_limit must be a positive, finite number of seconds, got {system_call_limit}"
            )
        self.buffer = StateBuffer()
        self.stats = RunStats()
        self.gui_enabled, self.host, self.port, self.duration = gui, host, check_port(port), duration
        token = check_token(token, host, generate=gui)
        self.token, self.share = token, share
        self._user_system, self._seed, self._num_workers = system, seed, num_workers
        self.backend = backend
        self._lock = threading.RLock()
        self._status_line = StatusLine()
        self._clock = PausableClock()  # the watchdog's clock: wall time that stands still while paused
        self.system_call_limit = system_call_limit
        if system is not None and observe != "state":
            raise ConfigError(
                f"observe={observe!r} rehearses sensing on the app's own simulation; your System chooses what it "
                "measures (return SystemState.sensors, state None), so leave observe at 'state'"
            )
        self._sensing = Sensing(observe, sensor_noise, sensor_delay, sensor_rate, estimator, estimator_config)
        self._session = build_session(
            task,
            optimizer,
            0,
            controller_config=controller_config,
            optimizer_config=optimizer_config,
            task_config=task_config,
            system=system,
            seed=seed,
            num_workers=num_workers,
            backend=backend,
            clock=self.watchdog_clock(),
            on_watchdog=self._on_watchdog,
            sensing=self._sensing,
            estimator_thread=True,  # the plant thread only reads, steps and serves (judo.runtime.estimator_thread)
        )
        self._configs: dict[ConfigKind, Config] = session_configs(self._session)
        self._pending: dict[ConfigKind, Config] = {}
        self._external_edits = 0
        self._switch_request: tuple[str, str] | None = None
        self._rebuild_requested = False
        self._reset_system = self._reset_controller = False
        self._paused = False
        self._clock.resume()
        self._reset_from_user = False
        self._goal_moves: dict[int, tuple[np.ndarray, np.ndarray | None]] = {}  # mocap index -> (pos, quat)
        self._resets_done = 0
        self._recording = None
        self._stop = threading.Event()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopping: asyncio.Future | None = None  # done once a stop is requested, to end waits
        self._start_error: BaseException | None = None
        self._ready = threading.Event()
        self._finished = threading.Event()
        self._thread: threading.Thread | None = None
        self._ran = False
        self._running_loops = False
        self.gui = None  # the Gui while the app runs with one

    # ---- lifecycle -------------------------------------------------------------------------
    def start(self) -> None:
        """Run the loops in a background thread and return once they (and the GUI server) are up.

        Raises GuiStartError (or ConfigError) if the GUI server cannot start."""
        self._claim_run()
        self._thread = threading.Thread(target=self._run_in_thread, name="judo-app", daemon=True)
        self._thread.start()
        self._ready.wait()
        if self._start_error is not None:
            self._thread.join()
            raise self._start_error
        exit_guard.register(self)  # stopped at interpreter exit if the script never calls stop()

    def run(self) -> RunSummary:
        """Run the loops in this thread until `duration` is reached, `stop()`, Ctrl-C or SIGTERM.

        Raises GuiStartError (or ConfigError) if the GUI server cannot start."""
        self._claim_run()
        asyncio.run(self._main(handle_signals=threading.current_thread() is threading.main_thread()))
        return self.summary()

    def stop(self, timeout: float | None = 10.0) -> None:
        """Ask every loop to finish, and wait for them (when started with `start()`), at most `timeout` s.

        Takes effect within about a second: a planning cycle in flight is abandoned to its thread."""
        self._request_stop()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the app stops by itself (its `duration` reached); True if it did within `timeout`."""
        if self._thread is None:
            return self._stop.is_set()
        self._thread.join(timeout)
        return not self._thread.is_alive()

    @property
    def running(self) -> bool:
        """True from `start()`/`run()` until the loops have finished."""
        return self._ran and not self._finished.is_set()

    def summary(self) -> RunSummary:
        """Control rate, plan times, real-time factor and final reward of the run so far."""
        session = self._session
        return self.stats.summary(session.task_name, session.optimizer_name)

    def _claim_run(self) -> None:
        if self._ran:
            raise JudoError("this App has already run; create a new App to run again")
        self._ran = True

    # ---- what the GUI and scripts read ---------------------------------------------------------
    @property
    def session(self) -> Session:
        """The session in use: names, controller and plant. Replaced, never changed, on a switch."""
        return self._session

    @property
    def controller(self) -> Controller:
        """The controller in use; its configs change only at the top of a planning cycle."""
        return self._session.controller

    @property
    def paused(self) -> bool:
        """True while the plant and the planner are paused."""
        return self._paused

    @property
    def status(self) -> Status:
        """The latest status message."""
        return self._status_line.status

    @property
    def resets_done(self) -> int:
        """Counts task resets the plant has carried out, so the GUI knows when to reframe its camera."""
        return self._resets_done

    @property
    def external_edits(self) -> int:
        """Counts config changes not made through the GUI (reset, switch, `update_config`), so the GUI
        knows when to refresh its widgets."""
        return self._external_edits

    def configs(self) -> dict[ConfigKind, Config]:
        """The latest accepted config of each kind; a planning cycle may not have picked them up yet."""
        with self._lock:
            return dict(self._configs)
