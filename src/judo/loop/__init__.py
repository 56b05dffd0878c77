"""The closed loop as a library: a plant (`System`), a planner, and the one loop between them.

What a robot integrator reads, below the app, the GUI and the commands (it imports none of them):

    system.py           System (read_state, apply, step, reset, halt), MujocoSystem, DynamicsSystem; the one
                        gate every System call goes through (what is in flight, nothing after a stop)
    closed_loop.py      ClosedLoop: read -> plan (latency model) -> serve (watchdog, feedback) -> apply, step;
                        the control clock (when the next plan is due, in sim time or wall time)
    watchdog.py         the watchdog: how fresh the readings and the plan in force are, which of them is
                        to blame, and when to tell it
    plant_clock.py      PlantClock: when a System's next step() is due in wall time (the app's plant thread and
                        excite pace by it)
    latency.py          the latency model, and the prediction that compensates for it
    records.py          PlanRecord and StepRecord, what the loop tells its recorders
    sensing.py          rehearsed sensing (SensedSystem), the estimator choice, the sensing flags
    estimator_thread.py an estimator on a thread of its own, off the plant's critical path
    system_choice.py    a System by name: judo's simulator, the ROS 2 bridge, or module:Class

`SystemState`, the reading a System serves, is defined in `judo.core.reading` (the estimators below this
package read it too). Import each name from the module that defines it; `judo` exports those a user needs.
"""
