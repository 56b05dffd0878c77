"""The judo app: one asyncio event loop running the plant, the planner and the browser GUI side by side.

    app = judo.App(task="cartpole", optimizer="mppi")   # GUI at http://127.0.0.1:8080
    app.start()          # returns at once; the loops run in a background thread
    app.update_config("optimizer", {"sigma": 0.2})
    app.stop()
    print(app.summary())

Three coroutines share one StateBuffer:
- the system loop steps the plant at real-time pace, applies `controller.action(t)` from the latest
  plan, and publishes each new SystemState under "system";
- the controller loop plans at `control_freq` from the latest state, running `update_action` in a
  worker thread (`run_in_executor`) so the event loop never blocks on rollouts, and publishes the
  plan, rewards, traces and timing under "plan";
- the GUI loop draws state, traces and plots at about 30 Hz.
Other threads (the GUI's callbacks, a notebook) only write config objects and commands through
the methods below; the loops pick them up at the top of their next iteration.

A stop (`stop()`, Ctrl-C, SIGTERM) takes effect within about a second whatever the configs: every
wait is cut short by it, the planning cycle stops between optimizer iterations, and a call stuck in
a rollout or a slow reward is abandoned to its daemon thread rather than waited for.
"""

import asyncio
import functools
import logging
import math
import signal
import threading
import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from judo.core.config import Config, check_seed, with_updates
from judo.core.controller import Controller, ControllerConfig, PlanningCancelled, check_configs
from judo.core.errors import ConfigError, JudoError
from judo.core.optimizer import OptimizerConfig
from judo.core.registry import lookup_optimizer, lookup_task
from judo.core.task import TaskConfig
from judo.core.workers import DaemonThreadPool
from judo.runtime import exit_guard
from judo.runtime.address import check_port, check_token, is_loopback
from judo.runtime.session import Session, build_session, default_configs
from judo.runtime.state_buffer import StateBuffer
from judo.runtime.stats import RunStats, RunSummary
from judo.runtime.system import MujocoSystem, SimulationDiverged, System, SystemState

logger = logging.getLogger("judo.app")

ConfigKind = Literal["controller", "optimizer", "task"]
CONFIG_KINDS: tuple[ConfigKind, ...] = ("controller", "optimizer", "task")

MAX_CATCH_UP = 0.1
"""Most seconds of sim time the system loop steps at once to catch up; beyond that it falls behind."""
IDLE_POLL = 0.01
"""Seconds a loop sleeps while paused or waiting for its first input."""
IDLE_THREAD_JOIN = 0.1
"""Seconds a stop waits for the planning thread to end before leaving it to finish on its own."""
GUI_PERIOD = 1.0 / 30.0
"""Seconds between GUI frames."""
MAX_WORKERS = 1024
"""Most rollout threads an app may ask for."""
REPEAT_LOG_INTERVAL = 5.0
"""Seconds before the same status message is written to the log again."""
CONFIG_POLL = 0.25
"""Most seconds the controller loop waits before looking at control_freq again (an edit takes effect)."""


class _Stopping(Exception):
    """Raised inside the loops when a stop arrives while they wait for the planning thread."""


@dataclass(frozen=True)
class SystemSnapshot:
    """What the system loop publishes under "system": the plant reading of one session."""

    generation: int
    reading: SystemState


@dataclass(frozen=True)
class PlanSnapshot:
    """What the controller loop publishes under "plan" after each planning cycle.

    Attributes:
        generation: the session that planned.
        time: sim time of the state planned from.
        nominal_knots: (num_nodes, nu) knots of the new plan.
        rewards: (num_rollouts,) rewards of the last iteration (index 0 is the nominal).
        traces: (1 + num_shown, T, num_trace_sensors, 3) trace-sensor positions, nominal first.
        plan_time: wall-clock seconds the cycle took.
    """

    generation: int
    time: float
    nominal_knots: np.ndarray
    rewards: np.ndarray
    traces: np.ndarray
    plan_time: float


@dataclass(frozen=True)
class Status:
    """The GUI's status line: the latest message, its level, and a count that grows with each report."""

    message: str
    level: Literal["info", "warning", "error"]
    count: int


class App:
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
        self.buffer = StateBuffer()
        self.stats = RunStats()
        self.gui_enabled, self.host, self.port, self.duration = gui, host, check_port(port), duration
        token = check_token(token, host, generate=gui)
        self.token, self.share = token, share
        self._user_system, self._seed, self._num_workers = system, seed, num_workers
        self.backend = backend
        self._lock = threading.RLock()
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
        )
        self._configs: dict[ConfigKind, Config] = self._session_configs(self._session)
        self._pending: dict[ConfigKind, Config] = {}
        self._external_edits = 0
        self._switch_request: tuple[str, str] | None = None
        self._reset_system = self._reset_controller = False
        self._paused = False
        self._reset_from_user = False
        self._goal_moves: dict[int, tuple[np.ndarray, np.ndarray | None]] = {}  # mocap index -> (pos, quat)
        self._resets_done = 0
        self._trouble: set[str] = set()  # loops whose last report was a failure, until they recover
        self._status = Status("starting", "info", 0)
        self._logged_at: dict[str, float] = {}
        self._stop = threading.Event()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopping: asyncio.Future | None = None  # done once a stop is requested, to end waits
        self._start_error: BaseException | None = None
        self._ready = threading.Event()
        self._finished = threading.Event()
        self._thread: threading.Thread | None = None
        self._ran = False
        self._running_loops = False
        self.gui: Any = None  # the Gui while the app runs with one

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

    def _request_stop(self) -> None:
        """Set the stop flag and wake every loop that waits (from any thread)."""
        self._stop.set()
        loop = self._loop
        if loop is not None:
            try:
                loop.call_soon_threadsafe(self._wake_on_stop)
            except RuntimeError:  # the loop has already closed
                pass

    def _wake_on_stop(self) -> None:
        if self._stopping is not None and not self._stopping.done():
            self._stopping.set_result(None)

    def _run_in_thread(self) -> None:
        try:
            asyncio.run(self._main())
        except BaseException as err:  # before the loops started, start() raises it; later, log it
            if err is not self._start_error:
                logger.error("the judo app failed", exc_info=err)

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
        return self._status

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

    # ---- commands (any thread) -----------------------------------------------------------------
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
            self._configs[kind] = updated
            self._pending[kind] = updated
            if not from_gui:
                self._external_edits += 1
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
        self.report("paused")

    def resume(self) -> None:
        """Undo `pause()`."""
        self._paused = False
        session = self._session
        self.report(f"running {session.task_name} with {session.optimizer_name}")

    def reset_task(self) -> None:
        """Reset the plant to its start state and forget the plan."""
        with self._lock:
            self._reset_system = self._reset_controller = True
            self._reset_from_user = True

    def move_goal(self, index: int, position: np.ndarray, quat: np.ndarray | None = None) -> None:
        """Move mocap body `index` (a goal) of the simulated plant to `position` (3,), and turn it to
        `quat` (4,) wxyz if given, before its next step.

        The planner sees it with the next state (the plant publishes its mocap poses). Raises JudoError
        for a user's System, whose goals the app cannot move, or an index the model does not have.
        """
        system = self._session.system
        if not isinstance(system, MujocoSystem):
            raise JudoError(f"cannot move goal {index}: the app drives your own {type(system).__name__}")
        nmocap = system.task.sim_model.nmocap
        if not 0 <= index < nmocap:
            raise JudoError(f"goal index must be in [0, {nmocap}), got {index}")
        with self._lock:
            turn = None if quat is None else np.array(quat, dtype=float).reshape(4)
            self._goal_moves[index] = (np.array(position, dtype=float).reshape(3), turn)

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

    def switch_optimizer(self, optimizer: str) -> None:
        """Use the registered optimizer `optimizer` from the next cycle, keeping the plant running."""
        lookup_optimizer(optimizer)
        with self._lock:
            task = self._switch_request[0] if self._switch_request else self._session.task_name
            self._switch_request = (task, optimizer)

    def report(self, message: str, level: Literal["info", "warning", "error"] = "info") -> None:
        """Show `message` on the status line and write it to the log (each message at most once every
        REPEAT_LOG_INTERVAL seconds, however the messages alternate)."""
        with self._lock:
            self._status = Status(message, level, self._status.count + 1)
            now = time.monotonic()
            if now - self._logged_at.get(message, -math.inf) < REPEAT_LOG_INTERVAL:
                return
            if len(self._logged_at) >= 64:  # forget messages not logged lately, so the table stays small
                self._logged_at = {m: t for m, t in self._logged_at.items() if now - t < REPEAT_LOG_INTERVAL}
            self._logged_at[message] = now
        logger.log({"info": logging.INFO, "warning": logging.WARNING, "error": logging.ERROR}[level], message)

    def _recovered(self, loop: str, message: str) -> None:
        """After a success of `loop`: if its failure is on the status line, replace it with `message`."""
        if loop not in self._trouble:
            return
        self._trouble.discard(loop)
        if self._status.level != "info":
            session = self._session
            self.report(f"{message}: running {session.task_name} with {session.optimizer_name}")

    # ---- the loops -----------------------------------------------------------------------------
    async def _main(self, handle_signals: bool = False) -> None:
        loop = asyncio.get_running_loop()
        self._stopping = loop.create_future()
        self._loop = loop
        if self._stop.is_set():  # stop() came before the loop existed
            self._stopping.set_result(None)
        if handle_signals:
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.add_signal_handler(sig, self._request_stop)
        self._executor = DaemonThreadPool(1, "judo-plan")
        try:
            if self.gui_enabled:
                from judo.runtime.gui import Gui  # viser is only imported when a GUI is wanted

                # viser moves to the next free port if this one is taken; raises GuiStartError if it cannot start
                self.gui = Gui(self, self.host, self.port, token=self.token, share=self.share)
                self._warn_if_exposed()
                logger.info("GUI at %s", self.gui.url)
            loops = [self._system_loop(), self._controller_loop()]
            if self.gui is not None:
                loops.append(self._gui_loop())
            self.report(f"running {self._session.task_name} with {self._session.optimizer_name}")
            tasks = [asyncio.create_task(coro) for coro in loops]
            self._running_loops = True
            self._ready.set()
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
            self._request_stop()  # a loop only returns when asked to stop, or on a bug: end the others
            for result in await asyncio.gather(*tasks, return_exceptions=True):
                if isinstance(result, BaseException):
                    logger.error("a judo loop failed", exc_info=result)
        except BaseException as err:
            if not self._running_loops:  # the GUI did not start: start() raises this once `_ready` is set
                self._start_error = err
            raise
        finally:
            self._stop.set()
            self._ready.set()
            if self.gui is not None:
                self.gui.close()
            # An idle planning thread ends at once and is joined; a cycle still in flight (a huge batch,
            # a slow reward) is not waited for: it ends in its own daemon thread.
            self._executor.shutdown(wait=True, timeout=IDLE_THREAD_JOIN)
            self._session.close()
            if handle_signals:
                for sig in (signal.SIGINT, signal.SIGTERM):
                    loop.remove_signal_handler(sig)
            self._loop = None
            self._finished.set()

    def _warn_if_exposed(self) -> None:
        """Log what a GUI listening beyond loopback exposes."""
        if is_loopback(self.host):
            return
        logger.warning(
            "the GUI listens on %s (%s): anyone who can reach port %d of this machine and has the URL with its "
            "token can change every config, switch the task, pause the plant or reset it, a real robot too. "
            "Prefer the default 127.0.0.1 and an SSH tunnel (docs/gui.md).",
            self.host,
            "every network interface" if self.host in ("0.0.0.0", "::") else "reachable from the network",
            self.gui.server.get_port(),
        )

    async def _sleep(self, seconds: float) -> None:
        """Wait `seconds`, or until a stop is requested, whichever comes first."""
        stopping = self._stopping
        if seconds > 0 and stopping is not None and not stopping.done():
            await asyncio.wait((stopping,), timeout=seconds)
        else:
            await asyncio.sleep(0)

    async def _in_worker(self, fn: Any, *args: Any) -> Any:
        """`fn(*args)` run on the planning thread; raises _Stopping if a stop comes first (the call is
        abandoned to its thread, which ends after it)."""
        assert self._stopping is not None
        future = asyncio.get_running_loop().run_in_executor(self._executor, fn, *args)
        await asyncio.wait((future, self._stopping), return_when=asyncio.FIRST_COMPLETED)
        if self._stop.is_set():
            future.cancel()  # drops the result whenever it comes
            raise _Stopping
        return future.result()

    async def _system_loop(self) -> None:
        """Step the plant at real-time pace: step k of a stretch is due at wall time origin + k * timestep."""
        generation = -1
        origin = last_wall = 0.0
        steps_done = 0
        paced = False
        while not self._stop.is_set():
            session = self._session
            system = session.system
            if session.generation != generation:
                generation, paced = session.generation, False
                self._publish_state(session)
            with self._lock:
                reset, self._reset_system = self._reset_system, False
            if reset:
                self._call_system(system.reset)
                paced = False
                self._publish_state(session)
                self._resets_done += 1
                with self._lock:
                    from_user, self._reset_from_user = self._reset_from_user, False
                if from_user:
                    self.report(f"{session.task_name} reset to its start state; the plan starts afresh")
            with self._lock:
                moves, self._goal_moves = self._goal_moves, {}
            if moves and isinstance(system, MujocoSystem):
                for index, (position, quat) in moves.items():
                    system.task.data.mocap_pos[index] = position
                    if quat is not None:
                        system.task.data.mocap_quat[index] = quat / np.linalg.norm(quat)
                self._publish_state(session)
            if self._paused:
                paced = False
                await self._sleep(IDLE_POLL)
                continue
            now = time.perf_counter()
            if not paced:
                origin, last_wall, steps_done, paced = now, now, 0, True
            dt = system.timestep
            due = int((now - origin) / dt) + 1 - steps_done
            max_steps = max(1, round(MAX_CATCH_UP / dt))
            if due > max_steps:  # too far behind to catch up: fall behind instead (the RTF shows it)
                origin += (due - max_steps) * dt
                due = max_steps
            if self.duration is not None:  # never step past the requested duration
                due = min(due, max(0, math.ceil((self.duration - self.stats.sim_time()) / dt - 1e-9)))
            for _ in range(due):
                self._step(session)
            steps_done += due
            self.stats.record_plant(due * dt, now - last_wall)
            last_wall = now
            if due:
                self._publish_state(session)
            if self.duration is not None and self.stats.sim_time() >= self.duration - 1e-9:
                self._request_stop()
                break
            await self._sleep(origin + steps_done * dt - time.perf_counter())

    def _step(self, session: Session) -> None:
        system = session.system
        try:
            reading = system.read_state()
            system.apply(session.controller.action(reading.time))
            system.step()
        except SimulationDiverged as err:
            self.report(str(err), "warning")
            with self._lock:
                self._reset_controller = True
        except Exception as err:  # a user's System or task hook failed; keep serving
            self._trouble.add("system")
            self.report(f"system step failed: {type(err).__name__}: {err}", "error")
        else:
            self._recovered("system", "the system steps again")

    def _call_system(self, method: Any) -> None:
        try:
            method()
        except Exception as err:
            self.report(f"system {method.__name__} failed: {type(err).__name__}: {err}", "error")

    def _publish_state(self, session: Session) -> None:
        try:
            reading = session.system.read_state()
        except Exception as err:
            self.report(f"system read_state failed: {type(err).__name__}: {err}", "error")
            return
        self.buffer.publish("system", SystemSnapshot(session.generation, reading))

    async def _controller_loop(self) -> None:
        try:
            while not self._stop.is_set():
                await self._apply_controller_requests()
                session = self._session
                snapshot = self.buffer.latest("system")
                if self._paused or snapshot is None or snapshot.value.generation != session.generation:
                    await self._sleep(IDLE_POLL)
                    continue
                start = time.perf_counter()
                await self._plan(session, snapshot.value.reading, start)
                await self._wait_out_period(start)
        except _Stopping:
            return

    async def _plan(self, session: Session, reading: SystemState, start: float) -> None:
        """One planning cycle from `reading`, published under "plan"; a failed cycle is reported and skipped."""
        controller = session.controller
        try:
            await self._in_worker(controller.update_action, reading.state, reading.time, reading.metadata, self._stop)
        except (PlanningCancelled, _Stopping):
            raise _Stopping from None
        except JudoError as err:  # NonFiniteRewardError, ConfigError: skip this cycle
            self._trouble.add("planner")
            self.report(f"planning cycle skipped: {err}", "warning")
        except Exception as err:  # an exception in the user's reward or hooks
            self._trouble.add("planner")
            self.report(f"planning cycle skipped: {type(err).__name__} in {session.task_name}: {err}", "error")
        else:
            self._recovered("planner", "planning works again")
            plan_time = time.perf_counter() - start
            rewards = controller.rewards
            assert controller.nominal_knots is not None  # set by every completed cycle
            self.stats.record_plan(start, plan_time, float(rewards[0]) if len(rewards) else float("nan"))
            plan = PlanSnapshot(
                session.generation, reading.time, controller.nominal_knots, rewards, controller.traces, plan_time
            )
            self.buffer.publish("plan", plan)

    async def _wait_out_period(self, start: float) -> None:
        """Wait until one control period after `start`, following edits of control_freq as they come."""
        while not self._stop.is_set():
            period = 1.0 / self._configs["controller"].control_freq  # type: ignore[attr-defined]
            remaining = start + period - time.perf_counter()
            if remaining <= 0:
                return
            await self._sleep(min(remaining, CONFIG_POLL))

    async def _apply_controller_requests(self) -> None:
        """Switches, resets and config edits queued since the last cycle; no cycle is in flight here."""
        with self._lock:
            switch, self._switch_request = self._switch_request, None
        if switch is not None and switch != (self._session.task_name, self._session.optimizer_name):
            await self._switch(*switch)
        with self._lock:
            pending, self._pending = self._pending, {}
            reset, self._reset_controller = self._reset_controller, False
        session = self._session
        controller = session.controller
        for kind, config in pending.items():
            if kind == "controller":
                controller.config = config  # type: ignore[assignment]
            elif kind == "optimizer":
                controller.optimizer.config = config
            else:
                controller.task.config = config
                if session.plant_task is not None:
                    session.plant_task.config = config
        if reset:
            controller.reset()

    async def _switch(self, task: str, optimizer: str) -> None:
        old = self._session
        if task == old.task_name:  # new optimizer on the running plant, keeping the tuned configs
            configs = self.configs()
            controller_config, task_config = configs["controller"], configs["task"]
            system, plant_task = old.system, old.plant_task
        else:
            controller_config = task_config = None
            system, plant_task = self._user_system, None
        make = functools.partial(
            build_session,
            task,
            optimizer,
            old.generation + 1,
            controller_config=controller_config,  # type: ignore[arg-type]
            task_config=task_config,  # type: ignore[arg-type]
            system=system,
            plant_task=plant_task,
            seed=self._seed,
            num_workers=self._num_workers,
            backend=self.backend,
        )

        def build() -> Session:
            session = make()
            if self._stop.is_set():  # the app stopped meanwhile and will not take it: free its threads
                session.close()
            return session

        try:
            new = await self._in_worker(build)
        except _Stopping:
            raise
        except Exception as err:
            self.report(f"could not switch to {task} with {optimizer}: {type(err).__name__}: {err}", "error")
            return
        with self._lock:
            self._session = new
            self._configs = self._session_configs(new)
            self._pending = {}
            self._external_edits += 1
        self.buffer.clear("plan")
        self._publish_state(new)
        old.close()
        self._trouble.clear()
        self.report(f"switched to {task} with {optimizer}{' (paused)' if self._paused else ''}")

    async def _gui_loop(self) -> None:
        while not self._stop.is_set():
            start = time.perf_counter()
            try:
                self.gui.update()
            except Exception as err:
                self.report(f"GUI update failed: {type(err).__name__}: {err}", "error")
            await self._sleep(start + GUI_PERIOD - time.perf_counter())

    @staticmethod
    def _session_configs(session: Session) -> dict[ConfigKind, Config]:
        controller = session.controller
        return {
            "controller": controller.config,
            "optimizer": controller.optimizer.config,
            "task": controller.task.config,
        }
