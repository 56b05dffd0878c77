"""The closed loop as a library: a plant (`System`), a planner, and the one loop between them.

What a robot integrator reads, below the app, the GUI and the commands (it imports none of them):

    system.py           System (read_state, apply, step, reset, halt), MujocoSystem, DynamicsSystem; the one
                        gate every System call goes through (what is in flight, nothing after a stop)
    closed_loop.py      ClosedLoop: read -> plan (latency model) -> serve (watchdog, feedback) -> apply, step
    timing.py           when the loop acts: ControlClock (when the next plan is due, in sim or wall
                        time), PlantClock (when a System's next step() is due in wall time), the
                        latency model and its prediction, PlanQueue (the plans waiting for their time),
                        and the watchdog (how fresh the readings and the plan in force are, which of
                        them is to blame, when to tell it) with the safe action it serves
    estimation.py       the estimator's side of the loop: fed every served action, run on each raw reading
    records.py          PlanRecord and StepRecord, what the loop tells its recorders
    sensing.py          rehearsed sensing (SensedSystem): a simulator seen through a robot's sensors

It imports only contracts (judo.core's task, planner, estimator, reading, errors) and the safety
layer: which System a command line names is `judo.system_choice`'s, how a command's plant is
observed `judo.evaluation.sensing`'s, and the app's estimator thread
`judo.runtime.running.estimator_thread`'s.

`SystemState`, the reading a System serves, is defined in `judo.core.reading` (the estimators below
this package read it too). Import each name from the module that defines it; `judo` exports those a
user needs.
"""  # noqa: E501
