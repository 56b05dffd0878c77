"""Start here: the contracts every task, optimizer, policy, estimator and planner fulfils, and the
one MPC loop.

- `task.py`: a MuJoCo model plus a reward over batches of rollouts (write a task: subclass `Task`);
- `optimizer.py`: sample control knots around a nominal, update it from rewards (write an
  optimizer);
- `controller.py`: one control update, written once (shift, sample, roll out, score, update);
- `planner.py`: what the closed loop and the app call on a controller;
- `policy.py`, `estimator.py`, `reading.py` (`SystemState`): a learned policy, a state estimator, a
  reading (checked, and put into an MjData for planning).

Beside them, in rooms by kind: `rollouts/` (the backends that step MuJoCo, and what runs inside a
rollout), `configuration/` (config classes, fields, TOML files and the name registries), `policies/`
(a policy as the controller, as proposals, from ONNX) and `commandline/` (the bounds and interrupts
every command shares).
"""
