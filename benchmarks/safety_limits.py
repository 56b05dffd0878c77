"""Safety limits, per case: commands served outside the limits (target 0), limit hits, and quality with vs without.

    PYTHONPATH=src python benchmarks/safety_limits.py --seeds 3 --duration 4

Cases (closed loop on judo's simulator, seeded):
- fence: cartpole with a cart-position fence |x| <= 0.3 m (with a 1.5 m/s speed cap), MPPI;
- rate: cartpole with a rate limit of 20 units/s on the push, MPPI;
- rogue: cartpole driven by a hand-written Policy that pushes into the fence at 1e9, under |x| <= 0.5 m, 0.5 m/s and an
  effort cap of 0.8;
- goal_outside: particle whose goals are drawn in +-0.45 m, inside a workspace box of +-0.2 m (0.5 m/s cap), MPPI;
- torque: quadruped at a tight torque limit, |kp (q_des - q) - kv dq| <= 12 N m on every joint (its forcerange is
  23.7), MPPI (slow: --cases torque).
For each: the served commands outside an effort or rate limit (recomputed from the log, not from the filter's count),
the plant steps beyond a position limit or the box and the largest overshoot (after the plant was first inside: a
random start may lie beyond), the serve filter's hits, the planning
iterations with no feasible sample, and the task's mean reward and quality metric with the limits and without them.
"""

import argparse

import numpy as np

from judo.core.policy import Policy
from judo.core.policy_controller import make_policy_controller
from judo.core.registry import make_controller
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.safety.limits import SafetyConfig, resolve


class Rogue(Policy):
    """Pushes the cart as hard as it can, always."""

    observation_size, action_size, horizon, metadata = 5, 1, 1, {}

    def act(self, observations: np.ndarray) -> np.ndarray:
        return np.full((len(observations), 1, 1), 1e9)


BOX = {"workspace_frame": "particle", "workspace_low": (-0.2, -0.2, -1.0), "workspace_high": (0.2, 0.2, 1.0)}
CASES = {  # task, optimizer (None: the rogue Policy), limits, quality metric
    "fence": ("cartpole", "mppi", SafetyConfig(position=("slider=-0.3:0.3",), velocity=("slider=1.5",)), "balanced_fraction"),
    "rate": ("cartpole", "mppi", SafetyConfig(rate=("push=20",)), "balanced_fraction"),
    "rogue": (
        "cartpole", None, SafetyConfig(position=("slider=-0.5:0.5",), velocity=("slider=0.5",), effort=("push=0.8",)),
        "balanced_fraction",
    ),
    "goal_outside": ("particle", "mppi", SafetyConfig(velocity=("x=0.5", "y=0.5"), **BOX), "goals_reached"),
    "torque": ("quadruped", "mppi", SafetyConfig(effort=("*=12",)), "final_distance"),
}  # fmt: skip


def outside(task, config: SafetyConfig, log) -> tuple[int, int, float]:
    """(commands outside an effort or rate limit, steps beyond a position limit or the box once the plant had been
    inside, the largest such overshoot in m or rad)."""
    limits = resolve(task, config)
    nq, dt = task.model.nq, task.model.opt.timestep
    before = np.vstack([log.states[:1], log.states[:-1]])  # the state each command was served in
    bad = np.zeros(len(log.controls), dtype=bool)
    if len(limits.effort):
        force = limits.effort_of(log.controls, before[:, :nq], before[:, nq:])
        bad |= (np.abs(force) > limits.effort_max * (1 + 1e-9)).any(axis=1)
    if len(limits.rate):
        steps = np.abs(np.diff(log.controls[:, limits.rate_actuator], axis=0)) / dt
        bad[1:] |= (steps > limits.rate_max * (1 + 1e-9)).any(axis=1)
    over = np.zeros(len(log.states))
    if len(limits.position):
        q = log.states[:, limits.position_index]
        over = np.maximum(limits.position_low - q, q - limits.position_high).max(axis=1)
    if limits.workspace_frame:
        frame = (
            log.states[:, limits.frame_qpos] if limits.frame_qpos is not None else log.sensors[:, limits.frame_sensor]
        )
        beyond = np.maximum(limits.workspace_low - frame, frame - limits.workspace_high).max(axis=1)
        over = np.maximum(over, beyond)
    entered = np.maximum.accumulate(over <= 1e-9)  # a start beyond a limit counts only once the plant was inside
    over = np.where(entered, over, 0.0)
    return int(bad.sum()), int((over > 1e-9).sum()), float(max(0.0, over.max()))


def episode(case: str, seed: int, duration: float, limited: bool):
    task, optimizer, config, _ = CASES[case]
    if optimizer is None:
        controller = make_policy_controller(task, Rogue(), seed=seed)
    else:
        controller = make_controller(task, optimizer, seed=seed)
    with controller:
        system = MujocoSystem.from_task(controller.task, seed=seed)
        result = run_episode(controller, system, duration, seed=seed, safety=config if limited else None)
    return result, outside(controller.task, config, result.log)


def costs(repeats: int = 200) -> str:
    """The filter's cost per served action and the screen's per planning cycle, against the update's (cartpole, mppi,
    every kind of limit the filter predicts)."""
    from time import perf_counter

    from judo.safety.feasibility import RolloutScreen
    from judo.safety.serve_filter import ServeFilter

    config = SafetyConfig(
        position=("slider=-0.5:0.5",), velocity=("slider=1.5",), effort=("push=0.8",), rate=("push=20",),
        workspace_frame="tip", workspace_low=(-1.0, -1.0, -1.0), workspace_high=(1.0, 1.0, 2.0),
    )  # fmt: skip
    controller = make_controller("cartpole", "mppi", seed=0)
    task, state = controller.task, np.array([0.1, np.pi, 0.2, 0.0])
    limits = resolve(task, config)
    guard = ServeFilter(task, limits)
    started = perf_counter()
    for i in range(repeats):
        guard.filter(np.array([0.3]), state, 0.01 * i, lambda: np.zeros(1))
    filter_us = 1e6 * (perf_counter() - started) / repeats
    update = []
    for i in range(20):
        started = perf_counter()
        controller.update_action(state, 0.02 * i)
        update.append(perf_counter() - started)
    full, sensors = controller.backend.rollout(controller._initial_state, controller.batch_controls, None)
    states, controls = full[..., 1:], controller.batch_controls
    screen = RolloutScreen(limits, task.dt, task.model.nq)
    started = perf_counter()
    for _ in range(20):
        screen.screen(np.zeros(len(states)), states, sensors, controls, np.zeros(1), 1)
    screen_ms = 1e3 * (perf_counter() - started) / 20 * controller.config.iterations_per_cycle
    update_ms = 1e3 * float(np.median(update))
    controller.close()
    return (
        f"cost: the serve filter {filter_us:.0f} us per served action; the rollout screen {screen_ms:.2f} ms per "
        f"planning cycle of {states.shape[0]} x {states.shape[1]} steps = {100 * screen_ms / update_ms:.1f}% of the "
        f"median update ({update_ms:.1f} ms), and the filter at 50 Hz x 2 steps per plan "
        f"{100 * 2 * filter_us / 1e3 / update_ms:.1f}%"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", nargs="+", default=[c for c in CASES if c != "torque"], choices=list(CASES))
    parser.add_argument("--no-cost", action="store_true", help="skip the filter's and the screen's cost")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--duration", type=float, default=4.0)
    args = parser.parse_args()
    print(
        f"{'case':12} {'limits':6} {'cmds outside':>12} {'steps beyond':>12} {'overshoot':>9} {'hits':>6} "
        f"{'no feasible':>11} {'mean reward':>11} quality"
    )
    for case in args.cases:
        for limited in (False, True):
            rows = [episode(case, seed, args.duration, limited) for seed in range(args.seeds)]
            cmds = sum(row[1][0] for row in rows)
            beyond = sum(row[1][1] for row in rows)
            overshoot = max(row[1][2] for row in rows)
            hits = sum(sum(row[0].limit_hits.values()) for row in rows)
            no_feasible = sum(row[0].no_feasible for row in rows)
            reward = np.mean([row[0].metrics["mean_reward"] for row in rows])
            metric = CASES[case][3]
            quality = np.mean([row[0].metrics[metric] for row in rows])
            print(
                f"{case:12} {'on' if limited else 'off':6} {cmds:12d} {beyond:12d} {overshoot:9.3f} {hits:6d} "
                f"{no_feasible:11d} {reward:11.2f} {metric} {quality:.2f}",
                flush=True,
            )
    if not args.no_cost:
        print(costs())


if __name__ == "__main__":
    main()
