"""Safety: what the robot's owner allows, held whatever the planner does.

- `judo.safety.stop`: the latched stop (a GUI button and key, SIGUSR1, /judo/estop, a robot link's
  e-stop), which serves the safe action or the System's halt until an explicit clear, across
  restarts.
- `judo.safety.config`: `SafetyConfig` (the `[safety.TASK]` section of a config file: the owner's
  joint, velocity, effort, rate, workspace and contact limits);
- `judo.safety.limits`: `resolve`, its load checks against the planning model (`Limits`);
- `judo.safety.feasibility`: `RolloutScreen`, which scores a rollout that crosses a hard limit -inf
  before any optimizer ranks it;
- `judo.safety.serve_filter`: `ServeFilter`, the last-line filter on every served command, whatever
  the planner.
"""
