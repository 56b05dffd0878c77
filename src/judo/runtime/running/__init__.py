"""The app's running parts, a room each: the planner runner on the event loop, the plant runner on a
thread of its own, and the supervisor that runs them until a stop, then stops every part in order.

Who runs what:
- **The planner runner** (`PlannerRunner`, planner.py), a coroutine on the app's event loop. At the
  top of each iteration it carries out what the commands queued in the app's state (a switch of
  task, optimizer or estimator; config edits; forgetting the plans after a reset), so it is the only
  writer of the session's configs and the only builder of sessions after the first. When the control
  clock (`judo.loop.timing.ControlClock`, the one `ClosedLoop.step` uses in sim time) says a
  plan is due, it plans from the closed loop's latest reading on its worker thread
  (`run_in_executor`), so the event loop never blocks on rollouts, and publishes the plan, rewards,
  traces and timing under "plan" in the StateBuffer (the GUI's view).
- **The plant runner** (`PlantRunner`, plant.py), the System driven from one thread of its own at
  real-time pace: the only caller of the closed loop's `advance` (serve, apply, step, read back), of
  the plant's resets and of `halt`. The plant clock (`judo.loop.timing.PlantClock`, the one
  `excite` paces by) says which steps are due: step k of a stretch at wall time origin + k *
  timestep; a loop that falls further behind than MAX_CATCH_UP s at once falls behind instead (the
  real-time factor shows it). judo's own simulator waits for a slow planner (`sim_waits`), so on a
  slow machine the simulation slows down; a user's System (a robot) is never held back. Off the
  event loop, a driver that blocks freezes neither the GUI nor planning. The plant is halted on a
  pause and on the way out of a stop.
- **The supervisor** (`Supervisor`, supervisor.py), one asyncio event loop that runs the planner
  runner (and its count of a late cycle's seconds), the plant runner's watch of the plant thread's
  System calls (`PlantRunner.watch`: it reports a call that blocks and halts the robot where the
  System can) and draws the frontend's frames (about 30 Hz). viser's own threads serve the browser
  and run the GUI's callbacks, which only queue commands.

The stop order, whatever started it (`App.stop()`, Ctrl-C, SIGTERM, the duration reached, a dead
plant thread): the stop signal wakes every wait; the plant thread gets PLANT_THREAD_JOIN s to halt
the plant and end, then no System call may start; the recording under way is written; the frontend
closes; the planning thread ends (a cycle still in flight is abandoned to its daemon thread); the
session's rollout and filter threads end.

The frontend is anything with `url`, `update()` (one frame) and `close()`, built from the App's
command port (`judo.runtime.command_port.AppPort`) by a `FrontendFactory`. judo's own is the viser
GUI (`judo.runtime.gui.gui.Gui`), looked up by name (VISER_FRONTEND) when an App is started with
gui=True, so viser is imported only then.

The exit guard (`stop_at_exit`, supervisor.py) stops every running App before the interpreter
finalizes. A script that ends (or raises) without `app.stop()` leaves the app's thread and the
rollout threads running: they are daemon threads, so Python would finalize the interpreter under
them while they are still inside MuJoCo, and the process would die with SIGSEGV (rc 139) in most
runs. `atexit` hooks run after the main thread ends and before finalization, so the one hook here
stops each App that `stop_at_exit` was given and waits for its threads. The hook is (re-)registered
on each `stop_at_exit`, after the GUI server started, so it runs before viser's own exit hook
(atexit runs the last registered first): the app stops its GUI itself.
"""
