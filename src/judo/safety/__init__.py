"""Safety: what the robot's owner allows, held whatever the planner does.

- `judo.safety.stop`: the latched stop (a GUI button and key, SIGUSR1, /judo/estop, a robot link's e-stop), which
  serves the safe action or the System's halt until an explicit clear, across restarts.
"""
