"""The judo app: one asyncio event loop running the plant, the planner and the browser GUI side by side.

    app = judo.App(task="cartpole", optimizer="mppi")   # GUI at http://localhost:8080
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
"""

import asyncio
import functools
import logging
import math
import signal
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from judo.core.config import Config, with_updates
from judo.core.controller import Controller, ControllerConfig, check_configs
from judo.core.errors import ConfigError, JudoError
from judo.core.optimizer import OptimizerConfig
from judo.core.registry import lookup_optimizer, lookup_task
from judo.core.task import TaskConfig
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
GUI_PERIOD = 1.0 / 30.0
"""Seconds between GUI frames."""
REPEAT_LOG_INTERVAL = 5.0
"""Seconds before the same status message is written to the log again."""


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
        gui: serve the viser GUI at http://host:port.
        duration: stop after this many seconds of sim time; None runs until `stop()`.
        seed: seeds the optimizer, the task and the simulated plant.
        num_workers: rollout threads; the number of cores by default.

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
        host: str = "0.0.0.0",
        port: int = 8080,
        duration: float | None = None,
        seed: int | None = None,
        num_workers: int | None = None,
    ) -> None:
        if duration is not None and not duration > 0:
            raise ConfigError(f"duration must be positive seconds of sim time, got {duration}")
        self.buffer = StateBuffer()
        self.stats = RunStats()
        self.gui_enabled, self.host, self.port, self.duration = gui, host, port, duration
        self._user_system, self._seed, self._num_workers = system, seed, num_workers
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
        self._last_logged: tuple[str, float] = ("", 0.0)
        self._stop = threading.Event()
        self._ready = threading.Event()
        self._finished = threading.Event()
        self._thread: threading.Thread | None = None
        self._ran = False
        self.gui: Any = None  # the Gui while the app runs with one

    # ---- lifecycle -------------------------------------------------------------------------
    def start(self) -> None:
        """Run the loops in a background thread and return once they (and the GUI server) are up."""
        self._claim_run()
        self._thread = threading.Thread(target=lambda: asyncio.run(self._main()), name="judo-app", daemon=True)
        self._thread.start()
        self._ready.wait()

    def run(self) -> RunSummary:
        """Run the loops in this thread until `duration` is reached, `stop()`, Ctrl-C or SIGTERM."""
        self._claim_run()
        asyncio.run(self._main(handle_signals=threading.current_thread() is threading.main_thread()))
        return self.summary()

    def stop(self, timeout: float | None = 10.0) -> None:
        """Ask every loop to finish, and wait for them (when started with `start()`)."""
        self._stop.set()
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
        """Show `message` on the status line and write it to the log (repeats at most every few seconds)."""
        with self._lock:
            self._status = Status(message, level, self._status.count + 1)
            now = time.monotonic()
            last_message, last_time = self._last_logged
            if message == last_message and now - last_time < REPEAT_LOG_INTERVAL:
                return
            self._last_logged = (message, now)
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
        if handle_signals:
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.add_signal_handler(sig, self._stop.set)
        self._executor = ThreadPoolExecutor(1, thread_name_prefix="judo-plan")
        try:
            loops = [self._system_loop(), self._controller_loop()]
            if self.gui_enabled:
                from judo.runtime.gui import Gui  # viser is only imported when a GUI is wanted

                self.gui = Gui(self, self.host, self.port)  # viser moves to the next free port if this one is taken
                logger.info("GUI at %s", self.gui.url)
                loops.append(self._gui_loop())
            self.report(f"running {self._session.task_name} with {self._session.optimizer_name}")
            tasks = [asyncio.create_task(coro) for coro in loops]
            self._ready.set()
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
            self._stop.set()  # a loop only returns when asked to stop, or on a bug: end the others
            for result in await asyncio.gather(*tasks, return_exceptions=True):
                if isinstance(result, BaseException):
                    logger.error("a judo loop failed", exc_info=result)
        finally:
            self._stop.set()
            self._ready.set()
            if self.gui is not None:
                self.gui.close()
            self._executor.shutdown(wait=True)
            self._session.close()
            if handle_signals:
                for sig in (signal.SIGINT, signal.SIGTERM):
                    loop.remove_signal_handler(sig)
            self._finished.set()

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
                await asyncio.sleep(IDLE_POLL)
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
                self._stop.set()
                break
            await asyncio.sleep(max(0.0, origin + steps_done * dt - time.perf_counter()))

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
        loop = asyncio.get_running_loop()
        while not self._stop.is_set():
            await self._apply_controller_requests()
            session = self._session
            snapshot = self.buffer.latest("system")
            if self._paused or snapshot is None or snapshot.value.generation != session.generation:
                await asyncio.sleep(IDLE_POLL)
                continue
            reading = snapshot.value.reading
            controller = session.controller
            start = time.perf_counter()
            try:
                await loop.run_in_executor(
                    self._executor, controller.update_action, reading.state, reading.time, reading.metadata
                )
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
            period = 1.0 / controller.config.control_freq
            await asyncio.sleep(max(0.0, start + period - time.perf_counter()))

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
        build = functools.partial(
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
        )
        try:
            new = await asyncio.get_running_loop().run_in_executor(self._executor, build)
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
            await asyncio.sleep(max(0.0, start + GUI_PERIOD - time.perf_counter()))

    @staticmethod
    def _session_configs(session: Session) -> dict[ConfigKind, Config]:
        controller = session.controller
        return {
            "controller": controller.config,
            "optimizer": controller.optimizer.config,
            "task": controller.task.config,
        }
