"""The app's running parts: the planner runner on the event loop, the plant runner on a thread of its own, and
the supervisor that runs them until a stop, then stops every part in order.

Who runs what:
- **The planner runner** (`PlannerRunner`), a coroutine on the app's event loop. At the top of each iteration it
  carries out what the commands queued in the app's state (a switch of task, optimizer or estimator; config
  edits; forgetting the plans after a reset), so it is the only writer of the session's configs and the only
  builder of sessions after the first. When the control clock (`judo.loop.closed_loop.ControlClock`, the one
  `ClosedLoop.step` uses in sim time) says a plan is due, it plans from the closed loop's latest reading on its
  worker thread (`run_in_executor`), so the event loop never blocks on rollouts, and publishes the plan,
  rewards, traces and timing under "plan" in the StateBuffer (the GUI's view).
- **The plant runner** (`PlantRunner`), the System driven from one thread of its own at real-time pace: the
  only caller of the closed loop's `advance` (serve, apply, step, read back), of the plant's resets and of
  `halt`. The plant clock (`judo.loop.plant_clock.PlantClock`, the one `excite` paces by) says which steps are
  due: step k of a stretch at wall time origin + k * timestep; a loop that falls further behind than
  MAX_CATCH_UP s at once falls behind instead (the real-time factor shows it). judo's own simulator waits
  for a slow planner (`sim_waits`), so on a slow machine the simulation slows down; a user's System (a robot)
  is never held back. Off the event loop, a driver that blocks freezes neither the GUI nor planning. The plant
  is halted on a pause and on the way out of a stop.
- **The supervisor** (`Supervisor`), one asyncio event loop that runs the planner runner, watches the plant
  thread's System calls (it reports a call that blocks and halts the robot where the System can) and draws
  the frontend's frames (about 30 Hz). viser's own threads serve the browser and run the GUI's callbacks,
  which only queue commands.

The stop order, whatever started it (`App.stop()`, Ctrl-C, SIGTERM, the duration reached, a dead plant thread):
the stop signal wakes every wait; the plant thread gets PLANT_THREAD_JOIN s to halt the plant and end, then no
System call may start; the recording under way is written; the frontend closes; the planning thread ends (a
cycle still in flight is abandoned to its daemon thread); the session's rollout and filter threads end.

The frontend is anything with `url`, `update()` (one frame) and `close()`, built from the App's command port
(`judo.runtime.commands.AppPort`) by a `FrontendFactory`. judo's own is the viser GUI (`judo.runtime.gui.gui.Gui`),
looked up by name (VISER_FRONTEND) when an App is started with gui=True, so viser is imported only then.

The exit guard (`stop_at_exit`) stops every running App before the interpreter finalizes. A script that ends
(or raises) without `app.stop()` leaves the app's thread and the rollout threads running: they are daemon
threads, so Python would finalize the interpreter under them while they are still inside MuJoCo, and the
process would die with SIGSEGV (rc 139) in most runs. `atexit` hooks run after the main thread ends and before
finalization, so the one hook here stops each App that `stop_at_exit` was given and waits for its threads. The
hook is (re-)registered on each `stop_at_exit`, after the GUI server started, so it runs before viser's own exit
hook (atexit runs the last registered first): the app stops its GUI itself.
"""

import asyncio
import atexit
import dataclasses
import importlib
import logging
import math
import signal
import threading
import time
import weakref
from collections.abc import Callable, Coroutine
from typing import Any, Protocol

import numpy as np

from judo.core.errors import JudoError
from judo.core.feedback import FeedbackPlan
from judo.core.reading import SystemState
from judo.core.rollouts.backend import PlanningCancelled
from judo.core.rollouts.workers import DaemonThreadPool
from judo.loop.closed_loop import ClosedLoop, ControlClock
from judo.loop.plant_clock import PlantClock
from judo.loop.system import SimulationDiverged, SystemCallError, SystemClosedError
from judo.runtime.address import is_loopback
from judo.runtime.app_state import AppState, PendingConfigs, Stopping
from judo.runtime.commands import AppPort
from judo.runtime.cycles import PlanningCycle, cycle_seconds, cycle_size, seconds_text
from judo.runtime.live_recording import Recordings
from judo.runtime.session import Session, SessionMaker
from judo.runtime.snapshots import PlanSnapshot, StateBuffer, SystemSnapshot
from judo.runtime.status import Reports, RunStats
from judo.safety.stop import StopLatch

IDLE_POLL = 0.01
"""Seconds the planner sleeps while paused or waiting for its first reading."""
CONFIG_POLL = 0.25
"""Most seconds the planner waits before looking again (an edit of control_freq takes effect)."""
IDLE_THREAD_JOIN = 0.1
"""Seconds a stop waits for the planning thread to end before leaving it to finish on its own."""


class PlannerRunner:
    """Plans for the session in use at control_freq of wall time (see the module's docstring).

    Args:
        state: the app's state (the session, the requests, pause, stop).
        maker: builds the session that replaces the running one on a switch.
        buffer: where each plan is published for the GUI.
        stats: the run's figures (plan times, rewards).
        reports: the status line.
        recordings: the recording under way, finished on a switch of task or optimizer.
    """

    def __init__(
        self,
        *,
        state: AppState,
        maker: SessionMaker,
        buffer: StateBuffer,
        stats: RunStats,
        reports: Reports,
        recordings: Recordings,
    ) -> None:
        self._state, self._maker, self._buffer, self._stats = state, maker, buffer, stats
        self._reports, self._recordings = reports, recordings
        self.clock = ControlClock()
        self._executor = DaemonThreadPool(1, "judo-plan")

    async def run(self) -> None:
        """Plan until a stop (the stop signal must be bound to this event loop)."""
        state = self._state
        try:
            while not state.stop.is_set():
                await self._carry_out_requests()
                session = state.session
                resets = state.resets_done  # before the reading: a reset in between only makes the plan look stale
                reading = session.closed_loop.reading
                period = 1.0 / session.controller.config.control_freq
                now = time.perf_counter()
                if state.paused or reading is None:
                    self.clock.restart(now)  # a plan is due as soon as there is one to make
                    await state.stop.sleep(IDLE_POLL)
                elif not self.clock.due(now, period):
                    await state.stop.sleep(min(self.clock.remaining(now, period), CONFIG_POLL))
                else:
                    await self._plan(session, reading, now, resets, period)
                    self.clock.ticked(now, time.perf_counter() - now, period)
        except Stopping:
            return

    def close(self) -> None:
        """End the planning thread: at once when idle; a cycle still in flight (a huge batch, a slow reward) is
        not waited for beyond IDLE_THREAD_JOIN and ends on its own daemon thread."""
        self._executor.shutdown(wait=True, timeout=IDLE_THREAD_JOIN)

    async def _plan(self, session: Session, reading: SystemState, start: float, resets: int, period: float) -> None:
        """One planning cycle from `reading`, read after `resets` plant resets, published under "plan"; a failed
        cycle is reported and skipped. The optimizer iterations beyond max_opt_iters (iterations_per_second) run
        only while they fit in the control `period` (s) from `start`."""
        controller, reports, state = session.controller, self._reports, self._state
        with state.lock:
            configs = state.configs  # what the cycle will take up (the planner is their only writer)
            size = (
                None
                if configs.optimizer is None
                else cycle_size(session.controller.task, configs.controller, configs.optimizer)
            )
            estimate = math.nan if size is None else cycle_seconds(state.step_cost, size, configs.controller)
            cycle = PlanningCycle(state.stop, size, estimate)
        state.start_cycle(cycle)
        try:
            plan = await state.stop.in_worker(self._executor, session.closed_loop.plan, reading, cycle, start + period)
        except Stopping:
            raise
        except PlanningCancelled:
            if state.stop.is_set():
                raise Stopping from None
            reports.report(
                f"planning cycle cancelled after {cycle.elapsed():.1f} s: {cycle.reason}; the plan before stays"
            )
            return
        except JudoError as err:  # ConfigError, a bad reading: skip this cycle
            reports.failed("planner", f"planning cycle skipped: {err}", "warning")
            return
        except Exception as err:  # an exception in the user's reward or hooks
            reports.failed("planner", f"planning cycle skipped: {type(err).__name__} in {session.task_name}: {err}")
            return
        finally:
            state.start_cycle(None)
        if plan is None:  # no finite reward, or non-finite knots: the plan before stays in force
            reports.failed("planner", f"planning cycle skipped: {session.closed_loop.last_failure}", "warning")
            return
        reports.recovered("planner", "planning works again")
        if isinstance(plan, FeedbackPlan) and plan.feedback_error is not None:
            reports.report(f"plan served without feedback gains: {plan.feedback_error}", "warning")
        plan_time = time.perf_counter() - start
        rewards = controller.rewards
        assert controller.nominal_knots is not None  # set by every completed cycle
        self._stats.record_plan(start, plan_time, float(rewards[0]) if len(rewards) else float("nan"))
        if size is not None and controller.iterations_run > 0:  # the iterations that fitted in the period
            state.step_cost.record(dataclasses.replace(size, iterations=controller.iterations_run), plan_time)
        if cycle.late():  # the status line counted its time: say it is over
            reports.report(f"planned in {plan_time:.1f} s: {reports.running()}")
        snapshot = PlanSnapshot(
            session.generation, reading.time, controller.nominal_knots, rewards, controller.traces, plan_time, resets
        )
        self._buffer.publish("plan", snapshot)

    async def _carry_out_requests(self) -> None:
        """Switches, config edits and resets queued since the last look; no cycle is in flight here."""
        requests = self._state.take_planner_requests()
        old, pending = self._state.session, requests.configs
        names = (old.task_name, old.optimizer_name)
        if requests.switch is not None and (requests.rebuild or requests.switch != names):
            if await self._switch(*requests.switch):
                pending = PendingConfigs()  # the new session took the accepted configs
        session = self._state.session
        controller = session.controller
        if pending.controller is not None:
            controller.config = pending.controller
        if pending.optimizer is not None:
            assert controller.optimizer is not None, "a session where a policy plans takes no optimizer edits"
            controller.optimizer.config = pending.optimizer
        if pending.task is not None:
            controller.task.config = pending.task
            if session.simulated is not None:
                session.simulated.task.config = pending.task
        if requests.forget_plans:
            session.closed_loop.forget_plans()

    async def _switch(self, task: str, optimizer: str) -> bool:
        """Replace the session with one of `task` and `optimizer` (built on the worker thread); True if it worked."""
        state, old = self._state, self._state.session
        estimator_only = (task, optimizer) == (old.task_name, old.optimizer_name)  # a recording goes on
        if not estimator_only:
            self._recordings.finish("the task or optimizer was switched")
        with state.lock:
            sensing, configs = state.sensing, state.configs

        def build() -> Session:
            session = self._maker.switched(old, task, optimizer, sensing, configs)
            if state.stop.is_set():  # the app stopped meanwhile and will not take it: free its threads
                session.close()
            return session

        try:
            new = await state.stop.in_worker(self._executor, build)
        except Stopping:
            raise
        except Exception as err:
            self._reports.report(f"could not switch to {task} with {optimizer}: {type(err).__name__}: {err}", "error")
            return False
        with state.lock:
            state.install_session(new)
            if estimator_only:
                self._recordings.move_to(new)
        self._buffer.clear("plan")
        old.close()
        self._reports.line.trouble.clear()
        self.clock.restart(time.perf_counter())
        estimating = f" and the {new.estimator_name} estimator" if new.estimator_name else ""
        paused = " (paused)" if state.paused else ""
        self._reports.report(f"switched to {new.task_name} with {new.optimizer_name}{estimating}{paused}")
        return True


logger = logging.getLogger("judo.app")

IDLE_POLL = 0.01
"""Seconds the plant loop sleeps while paused."""
WAIT_REPORT = 2.0
"""Wall seconds the simulation waits for one planning cycle before the status line says so."""


def sim_waits(loop: ClosedLoop) -> bool:
    """Whether judo's own simulator waits before its next step (docs/gui.md; a robot never does): while the
    planning cycle in flight would take more than one control period of sim time, and between cycles while the
    plan in force would age past max(2 periods, max_plan_age / 2) (a planner thread late to start its next
    cycle); never after a failed cycle, so a failing planner still trips the watchdog."""
    config = loop.controller.config
    period, next_time = 1.0 / config.control_freq, loop.stepped_time + loop.system.timestep
    started = loop.cycle_started
    if started is not None:
        return next_time - started > period + 1e-9
    newest = max(loop.plan_stamp, loop.newest_stamp)  # a finished plan is in force from the next step on
    return not loop.last_cycle_failed and next_time - newest > max(2 * period, config.max_plan_age / 2)


def system_snapshot(session: Session, reading: SystemState) -> SystemSnapshot:
    """The "system" snapshot of `reading`, with the simulated plant's true state when an estimator runs."""
    plant = session.simulated
    truth = plant.plant_state() if plant is not None and session.closed_loop.estimator is not None else None
    return SystemSnapshot(session.generation, reading, truth)


class PlantRunner:
    """The plant thread of an App: steps the session's plant at real-time pace, carries out the plant's
    requests (resets, goal moves) and publishes each new reading under "system" for the GUI.

    Args:
        state: the app's shared state (the session in use, pause, the plant's requests).
        buffer: where the readings are published for the GUI.
        stats: the run's figures (sim time stepped, real-time factor).
        reports: the status line.
        duration: stop after this many seconds of sim time (None: run until stopped).
        request_stop: called when `duration` is reached.
    """

    def __init__(
        self,
        *,
        state: AppState,
        buffer: StateBuffer,
        stats: RunStats,
        reports: Reports,
        duration: float | None,
        request_stop: Callable[[], None],
    ) -> None:
        self._state, self._buffer, self._stats, self._reports = state, buffer, stats, reports
        self._duration, self._request_stop = duration, request_stop
        self._waiting_since: float | None = None  # wall time the simulation began to wait for the cycle in flight
        self._wait_reported = False
        self.thread = threading.Thread(target=self._drive_plant, name="judo-plant", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def _drive_plant(self) -> None:
        """The plant thread: step the plant at real-time pace until a stop; halt it on a pause and at the end."""
        generation = -1
        last_wall = time.perf_counter()
        clock, halted = PlantClock(), False
        session = self._state.session
        try:
            while not self._state.stop.is_set():
                session = self._state.session
                if session.generation != generation:
                    generation = session.generation
                    clock.restart()
                    self._read_and_publish(session)
                if self._carry_out_plant_requests(session):
                    clock.restart()
                if self._state.paused:
                    if not halted:
                        halted = self._halt(session, "paused")
                    clock.restart()
                    self._state.stop.wait(IDLE_POLL)
                    last_wall = time.perf_counter()  # paused time is not run time
                    continue
                halted = False
                now = time.perf_counter()
                dt = session.system.timestep
                due = clock.due(now, dt)  # a wait for the planner stays in the run's wall time: the RTF shows it
                if self._duration is not None:  # never step past the requested duration
                    due = min(due, max(0, math.ceil((self._duration - self._stats.sim_time()) / dt - 1e-9)))
                waits = not session.closed_loop.real_time  # judo's own simulator waits for a slow planner
                served = stepped = 0
                while stepped < due and not self._state.stop.is_set():
                    if waits and sim_waits(session.closed_loop):
                        break
                    served += self._step(session)
                    stepped += 1
                clock.stepped(stepped)
                if stepped < due:  # waiting for the planner: resume pacing from when it is done
                    clock.restart()
                    self._note_wait(True)
                elif stepped:
                    self._note_wait(False)
                self._stats.record_plant(served * dt, now - last_wall)  # only the ticks the plant got
                last_wall = now
                if stepped and session.closed_loop.reading is not None:
                    self._buffer.publish("system", system_snapshot(session, session.closed_loop.reading))
                if self._duration is not None and self._stats.sim_time() >= self._duration - 1e-9:
                    self._request_stop()
                    break
                wait = clock.wait(time.perf_counter(), dt) if clock.running else IDLE_POLL / 10
                self._state.stop.wait(wait)
            self._halt(session, "stopped")
        except SystemClosedError:  # the app stopped while a call was blocked: no further call
            return

    def _note_wait(self, waiting: bool) -> None:
        """Say once when the simulator has waited WAIT_REPORT s for one planning cycle, and when it goes on."""
        now = time.perf_counter()
        if not waiting:
            if self._wait_reported:
                self._reports.report(f"the planner caught up; the simulation goes on: {self._reports.running()}")
            self._waiting_since, self._wait_reported = None, False
            return
        if self._waiting_since is None:
            self._waiting_since = now
        elif not self._wait_reported and now - self._waiting_since > WAIT_REPORT:
            self._wait_reported = True
            self._reports.report(
                f"the simulation has waited {now - self._waiting_since:.1f} s for a planning cycle "
                "(it waits rather than let a cycle take more than one control period of sim time)",
                "warning",
            )

    def _halt(self, session: Session, why: str) -> bool:
        """Bring the plant to rest (the System's halt, or the safe action); True if it worked."""
        try:
            session.closed_loop.halt()
        except SystemClosedError:
            raise
        except Exception as err:
            self._reports.report(f"system halt ({why}) failed: {type(err).__name__}: {err}", "error")
            return False
        return True

    def _carry_out_plant_requests(self, session: Session) -> bool:
        """A reset or goal moves queued for the plant; True if the plant was reset."""
        requests = self._state.take_plant_requests()
        reset, moves = requests.reset, requests.goal_moves
        if reset:
            try:
                reading = session.closed_loop.reset_plant()
            except SystemClosedError:
                raise
            except Exception as err:  # the plan is not restarted as if the reset had worked
                self._reports.report(f"system reset failed: {type(err).__name__}: {err}; the plan was kept", "error")
            else:
                self._buffer.publish("system", system_snapshot(session, reading))
                self._state.note_plant_reset()
                if requests.reset_from_user:
                    self._reports.report(f"{session.task_name} reset to its start state; the plan starts afresh")
        plant = session.simulated
        if moves and plant is not None:
            for index, (position, quat) in moves.items():
                plant.task.data.mocap_pos[index] = position
                if quat is not None:
                    plant.task.data.mocap_quat[index] = quat / np.linalg.norm(quat)
            self._read_and_publish(session)
        return reset

    def _step(self, session: Session) -> bool:
        """One plant step; True if the plant got its action and its step."""
        try:
            session.closed_loop.advance()
        except SimulationDiverged as err:
            self._reports.report(str(err), "warning")
            self._state.note_divergence()
            return True
        except SystemCallError as err:  # a user's System or task hook failed; keep serving
            self._reports.failed("system", str(err))
            return err.served
        except SystemClosedError:
            raise
        except Exception as err:
            self._reports.failed("system", f"system step failed: {type(err).__name__}: {err}")
            return False
        self._reports.recovered("system", "the system steps again")
        return True

    def _read_and_publish(self, session: Session) -> None:
        try:
            reading = session.closed_loop.read()
        except SystemClosedError:
            raise
        except Exception as err:
            self._reports.report(f"system read_state failed: {type(err).__name__}: {err}", "error")
            return
        self._buffer.publish("system", system_snapshot(session, reading))


logger = logging.getLogger("judo.app")

VISER_FRONTEND = "judo.runtime.gui.gui:Gui"
"""module:class of the browser GUI built for gui=True."""


class Frontend(Protocol):
    """A GUI the app draws on its event loop."""

    @property
    def url(self) -> str:
        """Where a browser finds it."""
        ...

    def update(self) -> None:
        """Draw one frame: follow the app's state."""
        ...

    def close(self) -> None:
        """Stop serving."""
        ...


FrontendFactory = Callable[[AppPort], Frontend]
"""Builds a frontend of the App (its command port), on the app's event loop."""


class ServedApp(AppPort, Protocol):
    """An App with the settings of the GUI's server."""

    host: str
    port: int
    token: str | None
    share: bool


def viser_frontend(app: ServedApp) -> Callable[[], Frontend]:
    """Builds judo's viser GUI of `app` at http://app.host:app.port (the next free port if it is taken), warning
    when it listens beyond loopback. The function raises GuiStartError if the server cannot start."""

    def make() -> Frontend:
        module, _, name = VISER_FRONTEND.partition(":")
        gui_class = getattr(importlib.import_module(module), name)
        gui = gui_class(app, app.host, app.port, token=app.token, share=app.share)
        warn_if_exposed(app.host, gui.server.get_port())
        logger.info("GUI at %s", gui.url)
        return gui

    return make


def warn_if_exposed(host: str, port: int) -> None:
    """Log what a GUI listening on `host` beyond loopback exposes."""
    if is_loopback(host):
        return
    logger.warning(
        "the GUI listens on %s (%s): anyone who can reach port %d of this machine and has the URL with its "
        "token can change every config, switch the task, pause the plant or reset it, a real robot too. "
        "Prefer the default 127.0.0.1 and an SSH tunnel (docs/gui.md).",
        host,
        "every network interface" if host in ("0.0.0.0", "::") else "reachable from the network",
        port,
    )


logger = logging.getLogger("judo.app")

GUI_PERIOD = 1.0 / 30.0
"""Seconds between GUI frames."""
PLANT_WATCH_PERIOD = 0.05
"""Seconds between the monitor's looks at the plant thread's System call."""
PLANT_THREAD_JOIN = 1.0
"""Seconds a stop waits for the plant thread to halt the plant and end; a driver blocked longer is left."""


class Supervisor:
    """Runs an App's parts until a stop (see the module's docstring).

    Args:
        state: the app's state (its stop signal, the session in use).
        plant: the plant runner, started here.
        planner: the planner runner, run here.
        recordings: written at the stop.
        reports: the status line.
        system_call_limit: seconds a System call may block before it is reported and the robot halted.
        make_frontend: builds the GUI on the event loop's thread (None: no GUI); raises if it cannot start.
        stop_latch: the latched stop, engaged by SIGUSR1 where signals are handled, and said at start when latched.
    """

    def __init__(
        self,
        *,
        state: AppState,
        plant: PlantRunner,
        planner: PlannerRunner,
        recordings: Recordings,
        reports: Reports,
        system_call_limit: float,
        make_frontend: Callable[[], Frontend] | None,
        stop_latch: StopLatch | None = None,
    ) -> None:
        self._state, self._plant, self._planner = state, plant, planner
        self._recordings, self._reports = recordings, reports
        self._system_call_limit, self._make_frontend, self._stop_latch = system_call_limit, make_frontend, stop_latch
        self.frontend: Frontend | None = None  # while the loops run with a GUI
        self.start_error: BaseException | None = None  # why the GUI could not start
        self.ready = threading.Event()  # the loops run (or failed to start)
        self.finished = threading.Event()  # every part has stopped

    async def main(self, handle_signals: bool = False) -> None:
        """Run every part until a stop, then stop them in order. Raises what kept the GUI from starting."""
        state, loop = self._state, asyncio.get_running_loop()
        state.stop.bind()
        if handle_signals:
            for sig in (signal.SIGINT, signal.SIGTERM):
                loop.add_signal_handler(sig, state.stop.set)
            if (latch := self._stop_latch) is not None:
                loop.add_signal_handler(signal.SIGUSR1, latch.engage, "SIGUSR1")
        if self._stop_latch is not None:
            self._stop_latch.listen()  # a robot link's e-stop reaches it while the app runs
        running = False
        try:
            if self._make_frontend is not None:
                self.frontend = self._make_frontend()
            self._plant.start()
            coroutines: list[Coroutine[Any, Any, None]] = [self._planner.run(), self._watch_plant()]
            if self.frontend is not None:
                coroutines.append(self._draw_frontend(self.frontend))
            self._reports.report(self._reports.running())
            if self._stop_latch is not None and self._stop_latch.latched:
                self._reports.report(self._stop_latch.start_line(), "warning")
            tasks = [asyncio.create_task(coroutine) for coroutine in coroutines]
            running = True
            self.ready.set()
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
            state.stop.set()  # a loop only returns when asked to stop, or on a bug: end the others
            for result in await asyncio.gather(*tasks, return_exceptions=True):
                if isinstance(result, BaseException):
                    logger.error("a judo loop failed", exc_info=result)
        except BaseException as err:
            if not running:  # the GUI did not start: start() raises this once `ready` is set
                self.start_error = err
            raise
        finally:
            self._stop_in_order()
            if handle_signals:
                for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1):
                    loop.remove_signal_handler(sig)
            state.stop.unbind()
            self.finished.set()

    def _stop_in_order(self) -> None:
        state = self._state
        state.stop.set()
        self.ready.set()
        if self._plant.thread.ident is not None:
            self._plant.thread.join(PLANT_THREAD_JOIN)
        state.session.closed_loop.calls.close()  # a driver blocked in a call is left to return on its own thread
        self._recordings.finish("the app stopped")
        if self.frontend is not None:
            self.frontend.close()
        self._planner.close()
        state.session.close()
        if self._stop_latch is not None:
            self._stop_latch.close()

    async def _watch_plant(self) -> None:
        """Report a call into a user's System that has blocked longer than `system_call_limit` (once per block) and
        halt the robot where the System offers a halt; report when it returns. Show a late planning cycle's time.
        Ends on a stop."""
        state, reports = self._state, self._reports
        reported: tuple[str, float] | None = None
        late: tuple[object, int] | None = None  # the late cycle and the whole seconds last shown of it
        while not state.stop.is_set():
            late = self._show_late_cycle(late)
            session = state.session
            calls = session.closed_loop.calls
            # judo's own simulator never hangs in a call: a late step there is this process busy elsewhere (a page
            # that connects is sent the whole scene), not a driver to halt
            blocked = None if session.simulated is not None else calls.blocked(self._system_call_limit)
            if blocked is not None and reported is None:
                reported = blocked
                halting = calls.offers_halt()
                reports.report(
                    f"system {blocked[0]}() has not returned for {blocked[1]:.1f} s; "
                    + ("halting the robot" if halting else "the watchdog serves the safe action once it returns"),
                    "error",
                )
                if halting:  # on a thread of its own: the driver's halt may block too
                    threading.Thread(target=self._halt_quietly, daemon=True, name="judo-halt").start()
            elif blocked is None and reported is not None:
                reported = None
                reports.report(f"the system responds again: {reports.running()}")
            if not self._plant.thread.is_alive() and not state.stop.is_set():
                reports.report("the plant thread ended unexpectedly; stopping", "error")
                state.stop.set()
            await state.stop.sleep(PLANT_WATCH_PERIOD)

    def _show_late_cycle(self, shown: tuple[object, int] | None) -> tuple[object, int] | None:
        """Count a late planning cycle's seconds on the status line, once a second (logged once per cycle)."""
        cycle = self._state.cycle
        if cycle is None or not cycle.late() or cycle.is_set():
            return shown
        seconds = int(cycle.elapsed())
        if shown is not None and shown == (cycle, seconds):
            return shown
        size = "" if cycle.size is None else f" ({cycle.size}, est. {seconds_text(cycle.estimate)})"
        message = f"planning: {seconds} s so far{size}; Pause, Reset task or a smaller setting cancels it"
        if shown is None or shown[0] is not cycle:
            self._reports.report(message, "warning")
        else:
            self._reports.progress(message, "warning")
        return cycle, seconds

    def _halt_quietly(self) -> None:
        try:
            self._state.session.closed_loop.calls.halt()
        except Exception as err:
            self._reports.report(f"system halt failed: {type(err).__name__}: {err}", "error")

    async def _draw_frontend(self, frontend: Frontend) -> None:
        loop = asyncio.get_running_loop()
        while not self._state.stop.is_set():
            start = loop.time()
            try:
                frontend.update()
            except Exception as err:
                self._reports.report(f"GUI update failed: {type(err).__name__}: {err}", "error")
            await self._state.stop.sleep(start + GUI_PERIOD - loop.time())


class Stoppable(Protocol):
    """What the hook needs of an App."""

    def stop(self, timeout: float | None = ...) -> None: ...


EXIT_STOP_TIMEOUT = 5.0
"""Seconds the exit hook waits for each running App to stop (its planning cycle in flight to end)."""

_running: "weakref.WeakSet[Stoppable]" = weakref.WeakSet()
_lock = threading.Lock()


def stop_at_exit(app: Stoppable) -> None:
    """Have `app` stopped (`app.stop(EXIT_STOP_TIMEOUT)`) at interpreter exit if it is still running then.

    Call it once the app has started; stopping an app that already stopped does nothing harmful."""
    with _lock:
        _running.add(app)
        atexit.unregister(stop_running_apps)
        atexit.register(stop_running_apps)


def stop_running_apps() -> None:
    """Stop every registered App, each waited for at most EXIT_STOP_TIMEOUT seconds."""
    with _lock:
        apps = list(_running)
        _running.clear()
    for app in apps:
        try:
            app.stop(timeout=EXIT_STOP_TIMEOUT)
        except Exception:  # at exit, one app failing to stop must not skip the others
            pass
