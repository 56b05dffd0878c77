"""The app: a plant thread, a planner and a browser GUI around one closed loop (`judo.loop`); its
CLI.

app.py            App: checks its settings, builds the parts, start/run/stop; the commands' public face
app_state.py      AppState (the one lock and what the parts share)
command_port.py   AppPort (all the GUI sees of the app) and CommandPort (the commands it may call)
commands.py       check_app_settings, and Commands (validate each command, queue it in the state)
session.py        Session (a controller, its plant and their ClosedLoop), ConfigSet, SessionMaker
running/          who runs what, a room each: planner.py (the control clock in wall time, ClosedLoop.plan on a
                  worker thread, switches), plant.py (the System's own thread: ClosedLoop.advance at real-time
                  pace) and supervisor.py (the event loop, the frontend, the stop order, the exit guard)
exchange.py       what the threads run on together: StopSignal (the app's stop), the cycle in flight and its
                  cost, the StateBuffer (the published readings and plans), RunStats (the timing figures)
live_recording.py the recording under way
snapshots.py      the values published and shown: readings and plans as published, the figures, the cycle's cost
status.py         the status line and the reports
address.py        where the GUI listens
launch.py         `python -m judo`: the app's command line
gui/              the viser GUI (the app never imports it)
"""  # noqa: E501
