"""Safety limits, per case: commands served outside the limits (target 0), limit hits, and quality
with vs without.

    PYTHONPATH=src python benchmarks/safety_limits.py --seeds 20 --duration 4 --cost-cases all_kinds go2 grasp torque
    PYTHONPATH=src python benchmarks/safety_limits.py --cases grasp go2 --seeds 20 --duration 4 --no-cost
    PYTHONPATH=src python benchmarks/safety_limits.py --cases torque --seeds 20 --duration 2 --no-cost

Cases (closed loop on judo's simulator, seeded; the last three are slow and run only when named):
- joint_stop: pendulum, whose reward wants the pole upright (q = 0), with its hinge stopped 2 rad
  either side of hanging down (q in [pi - 2, pi + 2]) and 3 rad/s, MPPI;
- fence: cartpole with a cart-position fence |x| <= 0.3 m (with a 1.5 m/s speed cap), MPPI;
- rate: cartpole with a rate limit of 20 units/s on the push, MPPI;
- rogue: cartpole driven by a hand-written Policy that pushes into the fence at 1e9,
  under |x| <= 0.5 m, 0.5 m/s and an effort cap of 0.8;
- goal_outside: particle whose goals are drawn in +-0.45 m, inside a workspace box of +-0.2 m (0.5
  m/s cap), MPPI;
- goal_jumps: particle, whose goal jumps to a new place when reached, under a rate limit of 4
  units/s on both forces
  (their full range in 0.5 s), MPPI;
- torque: quadruped at a tight torque limit, |kp (q_des - q) - kv dq| <= 12 N m on every
  joint (forcerange 23.7);
- go2: go2_stand at a tight torque limit, |kp (q_des - q) - kd dq| <= 15 N m on every
  motor (forcerange 23.7 and
  45.4), MPPI;
- grasp: fr3_pick with a cap of 20 N (GRASP_CAP) on the total normal contact force on the
  cube (fingers and table).
For each: the served commands outside an effort or rate limit (recomputed from the log, not from the
filter's count); the plant steps beyond a position limit, the box or the contact cap (the cube's
contact force recomputed by mj_forward of each logged state and served command on the plant's model)
and the largest overshoot, counted once the plant was first inside (a random start may lie beyond);
the serve filter's hits; the planning iterations with no feasible sample; and the task's mean reward
and quality metric with the limits and without them. Last, the filter's cost per served action and
the rollout screen's per planning cycle against the update (--cost-cases).
"""  # noqa: E501

import argparse

import mujoco
import numpy as np

from judo.core.configuration.registry import make_controller
from judo.core.policies.policy_controller import make_policy_controller
from judo.core.policy import Policy
from judo.evaluation.episode import run_episode
from judo.loop.system import MujocoSystem
from judo.safety.config import SafetyConfig
from judo.safety.limits import resolve


class Rogue(Policy):
    """Pushes the cart as hard as it can, always."""

    observation_size, action_size, horizon, metadata = 5, 1, 1, {}

    def act(self, observations: np.ndarray) -> np.ndarray:
        return np.full((len(observations), 1, 1), 1e9)


STOP = f"hinge={np.pi - 2:.2f}:{np.pi + 2:.2f}"
"""The pendulum's stops, 2 rad either side of hanging down (pi): upright (0 or 2 pi) lies 1.14 rad
beyond each."""
GRASP_CAP = 20.0
"""N on the cube's contacts: 20 times its weight, a seventh of what the closed gripper squeezes it
with (140 N)."""
BOX = {
    "workspace_frame": "particle",
    "workspace_low": (-0.2, -0.2, -1.0),
    "workspace_high": (0.2, 0.2, 1.0),
}
CASES = {  # task, optimizer (None: the rogue Policy), limits, quality metric
    "joint_stop": ("pendulum", "mppi", SafetyConfig(position=(STOP,), velocity=("hinge=3",)), "final_angle_error"),  # noqa: E501
    "fence": ("cartpole", "mppi", SafetyConfig(position=("slider=-0.3:0.3",), velocity=("slider=1.5",)), "balanced_fraction"),  # noqa: E501
    "rate": ("cartpole", "mppi", SafetyConfig(rate=("push=20",)), "balanced_fraction"),
    "rogue": (
        "cartpole", None, SafetyConfig(position=("slider=-0.5:0.5",), velocity=("slider=0.5",), effort=("push=0.8",)),  # noqa: E501
        "balanced_fraction",
    ),
    "goal_outside": ("particle", "mppi", SafetyConfig(velocity=("x=0.5", "y=0.5"), **BOX), "goals_reached"),  # noqa: E501
    "goal_jumps": ("particle", "mppi", SafetyConfig(rate=("force_x=4", "force_y=4")), "goals_reached"),  # noqa: E501
    "torque": ("quadruped", "mppi", SafetyConfig(effort=("*=12",)), "final_distance"),
    "go2": ("go2_stand", "mppi", SafetyConfig(effort=("*=15",)), "standing_fraction"),
    "grasp": ("fr3_pick", "mppi", SafetyConfig(contact_geoms=("object",), max_contact_force=GRASP_CAP), "phase_reached"),  # noqa: E501
}  # fmt: skip
SLOW = ("torque", "go2", "grasp")
"""Cases left out by default (their updates take longer): --cases names them."""


def contact_force(model, limits, states: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """(T,) the largest total normal contact force (N) on a capped geom at each of the (T, nq + nv)
    states under the (T, nu) commands served in them: mj_forward on the plant's model, the contacts
    the step starts from."""
    data, wrench, nq = mujoco.MjData(model), np.zeros(6), model.nq
    force = np.zeros(len(states))
    for t, (state, ctrl) in enumerate(zip(states, controls, strict=True)):
        data.qpos[:], data.qvel[:], data.ctrl[:] = state[:nq], state[nq:], ctrl
        mujoco.mj_forward(model, data)
        totals = dict.fromkeys(limits.contact_ids.tolist(), 0.0)
        for i in range(data.ncon):
            contact = data.contact[i]
            touched = [g for g in (contact.geom1, contact.geom2) if g in totals]
            if touched and contact.efc_address >= 0:
                mujoco.mj_contactForce(model, data, i, wrench)
                for g in touched:
                    totals[g] += abs(wrench[0])
        force[t] = max(totals.values())
    return force


def outside(task, config: SafetyConfig, log, plant_model) -> tuple[int, int, float]:
    """(commands outside an effort or rate limit, steps beyond a position limit, the box or the
    contact cap once the plant had been inside, the largest such overshoot in m, rad or N)."""
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
            log.states[:, limits.frame_qpos]
            if limits.frame_qpos is not None
            else log.sensors[:, limits.frame_sensor]
        )
        beyond = np.maximum(limits.workspace_low - frame, frame - limits.workspace_high).max(axis=1)
        over = np.maximum(over, beyond)
    if len(limits.contact_ids):
        over = np.maximum(
            over,
            contact_force(plant_model, limits, before, log.controls) - limits.max_contact_force,
        )
    # a start beyond a limit counts only once the plant was inside
    entered = np.maximum.accumulate(over <= 1e-9)
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
        result = run_episode(
            controller, system, duration, seed=seed, safety=config if limited else None
        )
    return result, outside(controller.task, config, result.log, system.task.sim_model)


ALL_KINDS = SafetyConfig(
    position=("slider=-0.5:0.5",), velocity=("slider=1.5",), effort=("push=0.8",), rate=("push=20",),  # noqa: E501
    workspace_frame="tip", workspace_low=(-1.0, -1.0, -1.0), workspace_high=(1.0, 1.0, 2.0),
)  # fmt: skip
"""The cost case: cartpole under every kind of limit the rollout screen checks and the filter
predicts."""


def costs(case: str, repeats: int = 200) -> str:
    """The filter's cost per served action and the screen's per planning cycle, against the
    update's, on `case`'s task and limits ("all_kinds": cartpole, mppi, ALL_KINDS), from the task's
    start state."""
    from time import perf_counter

    from judo.safety.feasibility import RolloutScreen
    from judo.safety.serve_filter import ServeFilter

    task_name, optimizer, config, _ = (
        ("cartpole", "mppi", ALL_KINDS, "") if case == "all_kinds" else CASES[case]
    )
    controller = make_controller(task_name, optimizer or "mppi", seed=0)
    task = controller.task
    state = np.concatenate([task.data.qpos, task.data.qvel])
    limits = resolve(task, config)
    guard, command = ServeFilter(task, limits), task.optimizer_warm_start(state)
    started = perf_counter()
    for i in range(repeats):
        guard.filter(command, state, 0.01 * i, lambda: task.safe_action(state))
    filter_us = 1e6 * (perf_counter() - started) / repeats
    update = []
    for i in range(20):
        started = perf_counter()
        controller.update_action(state, 0.02 * i)
        update.append(perf_counter() - started)
    full, sensors = controller.backend.rollout(
        controller._initial_state, controller.batch_controls, None
    )
    states, controls = full[..., 1:], controller.batch_controls
    screen = RolloutScreen(limits, task.dt, task.model.nq)
    started = perf_counter()
    for _ in range(20):
        screen.screen(np.zeros(len(states)), states, sensors, controls, command, 1)
    screen_ms = 1e3 * (perf_counter() - started) / 20 * controller.config.iterations_per_cycle
    update_ms = 1e3 * float(np.median(update))
    # plant steps a plan
    per_plan = max(1.0, 1.0 / (controller.config.control_freq * task.sim_model.opt.timestep))
    controller.close()
    return (
        f"cost {case} ({task_name}): the serve filter {filter_us:.0f} us per served action; "
        "the rollout screen "
        f"{screen_ms:.2f} ms per planning cycle of {states.shape[0]} x {states.shape[1]} steps = "
        f"{100 * screen_ms / update_ms:.1f}% of the median update ({update_ms:.1f} ms); the "
        "filter at "
        f"{per_plan:.0f} served actions per plan "
        f"{100 * per_plan * filter_us / 1e3 / update_ms:.1f}%"
    )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--cases", nargs="+", default=[c for c in CASES if c not in SLOW], choices=list(CASES)
    )
    parser.add_argument(
        "--no-cost", action="store_true", help="skip the filter's and the screen's cost"
    )
    parser.add_argument(
        "--cost-cases",
        nargs="+",
        default=["all_kinds"],
        choices=["all_kinds", *CASES],
        help="where to time them",
    )
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--duration", type=float, default=4.0)
    args = parser.parse_args()
    print(
        f"{'case':12} {'limits':6} {'cmds outside':>12} {'steps beyond':>12} "
        f"{'overshoot':>9} {'hits':>6} "
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
                f"{case:12} {'on' if limited else 'off':6} {cmds:12d} {beyond:12d} "
                f"{overshoot:9.3f} {hits:6d} "
                f"{no_feasible:11d} {reward:11.2f} {metric} {quality:.2f}",
                flush=True,
            )
    if not args.no_cost:
        for case in args.cost_cases:
            print(costs(case), flush=True)


if __name__ == "__main__":
    main()
