"""Planning from what a robot measures: closed-loop quality with sensors + EKF against the full
state, and the EKF's cost on leap_cube.

    PYTHONPATH=src python benchmarks/estimation.py                     # cartpole, pendulum: 5 seeds x 8 s
    PYTHONPATH=src python benchmarks/estimation.py --tasks acrobot double_cartpole --seeds 5 --duration 15
    PYTHONPATH=src python benchmarks/estimation.py --tasks walker --seeds 5 --duration 15 --cost-steps 0 --true-start
    PYTHONPATH=src python benchmarks/estimation.py --tasks leap_cube --optimizer icem --seeds 5 --duration 30
    PYTHONPATH=src python benchmarks/estimation.py --tasks leap_cube --seeds 3 --duration 15 --planner-noise 0.002
    PYTHONPATH=src python benchmarks/estimation.py --cost-only           # just the leap_cube EKF cost

Each task runs on the same seeds (the plant's start state and the sensor noise are seeded) as
evaluate runs it (`run_seeded_episode`, the one seeded runner of evaluate, tune and collect):
- "full state": `evaluate`, the true [qpos, qvel] every step;
- "sensors + ekf": `evaluate --observe sensors --estimator ekf` with the task's sensing below: a
  SensedSystem serving only the measured sensors into the EKF, which fuses each reading at the time
  it was taken and predicts to now;
- "sensors + ukf": the same with the unscented Kalman filter (`--estimator ukf`): sigma points
  through mj_step instead of finite-difference Jacobians;
- "state, noisy + late": the "state" estimator (no filter) fed the same noise, rate and delay on a
  full state: qpos with the encoders' std, qvel with the std of differencing two such
  readings (sqrt(2) std x rate), both sampled at the encoders' rate and delivered as late. The gap
  to the EKF is what the filter buys. Only for the tasks whose sensing is one rate and delay for
  every sensor (not leap_cube);
- "ekf, ideal sensors": the EKF on the same measured sensors without noise or delay, read every
  plant step. It starts from the model's keyframe, as on a robot, not from the plant's seeded start
  state; what it loses against the full state is the filter's own loss (observability, contacts),
  apart from the sensors'.
- "ekf, ideal, true start" (with --true-start): the same, but the filter starts from the plant's
  true start state. What "ekf, ideal sensors" loses beyond it is the unknown start (walker starts in
  the air with random velocities that no sensor sees until a foot lands).
- "state + planner noise" (with --planner-noise STD): no estimator, the true state every plant step
  with Gaussian noise of std STD (m or rad, in the tangent space) on every position and none on the
  velocities. It measures how much noise the planner itself tolerates, whatever filter produced it.
The metric is the task's first metric (cartpole: balanced_fraction, walker: mean_forward_speed,
leap_cube: goals_per_minute), always from the true plant state.

The leap_cube cost: one EKF update (a finite-difference Jacobian of 2 nv = 44 state columns, ~45
mj_steps) against one mj_step of the same model in the same process, so the ratio holds on a loaded
machine, and the wall time (which does not). With relinearize_every=k the Jacobians are reused for k
steps. The "ukf" row is one UKF update: 88 sigma points through mj_step and the sensors, more for a
replayed late reading.
"""  # noqa: E501

import argparse
import dataclasses
import time
from collections import deque

import mujoco
import numpy as np

import judo
from judo.core.configuration.registry import make_controller, make_estimator
from judo.core.estimator import ControlHistory, Estimator
from judo.core.reading import SystemState
from judo.estimators.ekf import EKFConfig
from judo.estimators.ukf import UKFConfig
from judo.evaluation.episode import run_episode
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode
from judo.evaluation.sensing import Sensing
from judo.loop.sensing import SensedSystem
from judo.loop.system import MujocoSystem, System

ENCODERS = {"noise": 0.005, "rate": 100.0, "delay": 0.01}
"""The encoder setting of docs/estimation.md for cartpole, pendulum, acrobot and double_cartpole."""
WALKER_SENSING = {
    "noise": {
        "jointpos": 0.005,
        "framequat": float(np.deg2rad(0.5)),
        "gyro": 0.01,
        "accelerometer": 0.1,
    },
    "rate": 200.0,
    "delay": 0.005,
}
"""Encoders and a torso IMU (orientation, gyro, accelerometer) at 200 Hz, 5 ms late."""
LEAP_SENSING = {
    "noise": {"jointpos": 0.005, "framepos": 0.002, "framequat": float(np.deg2rad(1.0))},
    "rate": {"jointpos": 100.0, "framepos": 30.0, "framequat": 30.0},
    "delay": {"jointpos": 0.0, "framepos": 0.04, "framequat": 0.04},
}
"""The leap_cube setting of docs/estimation.md: encoders at 100 Hz, the cube's pose at 30 Hz, 2 mm
and 1 degree, 40 ms late."""
SENSING = {"walker": WALKER_SENSING, "leap_cube": LEAP_SENSING, "leap_cube_down": LEAP_SENSING}
"""Each task's sensing (ENCODERS for the others)."""


class NoisyLateState(System):
    """A simulated plant serving its full state the way raw encoders would give it: qpos with
    Gaussian noise (std `position_std`, applied in the tangent space, so free joints stay valid),
    qvel with `velocity_std`, sampled every `1 / rate` s and delivered `delay` s later, stamped with
    the time it was taken."""

    def __init__(self, system: MujocoSystem, position_std: float, velocity_std: float, rate: float, delay: float,  # noqa: E501
                 rng: np.random.Generator) -> None:  # fmt: skip
        self.system, self.task, self.timestep = system, system.task, system.timestep
        self.position_std, self.velocity_std, self.period, self.delay = (
            position_std,
            velocity_std,
            1 / rate,
            delay,
        )
        self.rng = rng
        self.in_flight: deque[tuple[float, SystemState]] = deque()
        self.reset()

    def plant_state(self) -> np.ndarray | None:
        return self.system.plant_state()

    def plant_sensors(self) -> np.ndarray:
        return self.task.data.sensordata.copy()

    def reset(self) -> None:
        self.system.reset()
        self.in_flight.clear()
        self.next_sample = self.task.data.time
        self.latest = self.sample()
        self.next_sample += self.period

    def apply(self, action: np.ndarray) -> None:
        self.system.apply(action)

    def step(self) -> None:
        self.system.step()
        now = self.task.data.time
        if now >= self.next_sample - 1e-9:
            self.in_flight.append((now + self.delay, self.sample()))
            self.next_sample += self.period
        while self.in_flight and self.in_flight[0][0] <= now + 1e-9:
            self.latest = self.in_flight.popleft()[1]

    def read_state(self) -> SystemState:
        return self.latest

    def sample(self) -> SystemState:
        model, data = self.task.sim_model, self.task.data
        qpos = data.qpos.copy()
        mujoco.mj_integratePos(model, qpos, self.rng.normal(0.0, self.position_std, model.nv), 1.0)
        qvel = data.qvel + self.rng.normal(0.0, self.velocity_std, model.nv)
        reading = self.system.read_state()
        return SystemState(
            np.concatenate([qpos, qvel]), float(data.time), reading.metadata, reading.sensors
        )


class TrueStart:
    """An estimator started from the plant's true state instead of the model's keyframe; otherwise
    `estimator`."""

    def __init__(self, estimator: Estimator, plant: MujocoSystem) -> None:
        self.estimator, self.plant = estimator, plant

    def reset(self, reading: SystemState) -> None:
        self.estimator.reset(dataclasses.replace(reading, state=self.plant.plant_state()))

    def update(self, reading: SystemState, time: float, controls: ControlHistory) -> SystemState:
        return self.estimator.update(reading, time, controls)


RATIO_NAMES = {
    "sensors + ekf": "ekf/full",
    "sensors + ukf": "ukf/full",
    "state, noisy + late": "state/full",
    "ekf, ideal sensors": "ideal/full",
    "ekf, ideal, true start": "true0/full",
    "state + planner noise": "noise/full",
}
"""The short name of each mode's ratio to the full state."""


def episode(
    task_name: str,
    optimizer: str,
    seed: int,
    duration: float,
    mode: str,
    planner_noise: float = 0.0,
    latency: float = 0.0,
) -> tuple[str, float]:
    """(name, value) of the task's first metric in one seeded episode, planned from the full state,
    the EKF or the "state" estimator on a noisy, late full state."""
    settings = SENSING.get(task_name, ENCODERS)
    if mode == "state + planner noise":
        controller = make_controller(task_name, optimizer, seed=seed, num_workers=1)
        plant = MujocoSystem.from_task(controller.task, seed)
        every_step = 1.0 / plant.timestep
        noisy = NoisyLateState(
            plant, planner_noise, 0.0, every_step, 0.0, np.random.default_rng([seed, 7])
        )
        with controller:
            state_estimator = make_estimator("state", controller.task, task_name=task_name)
            result = run_episode(
                controller, noisy, duration, latency, seed, estimator=state_estimator
            )  # type: ignore[arg-type]
    elif mode == "ekf, ideal, true start":
        controller = make_controller(task_name, optimizer, seed=seed, num_workers=1)
        plant = MujocoSystem.from_task(controller.task, seed)
        with controller:
            ekf = TrueStart(make_estimator("ekf", controller.task, task_name=task_name), plant)
            result = run_episode(
                controller, SensedSystem(plant), duration, latency, seed, estimator=ekf
            )  # type: ignore[arg-type]
    elif mode == "state, noisy + late":
        std, rate, delay = settings["noise"], settings["rate"], settings["delay"]
        controller = make_controller(task_name, optimizer, seed=seed, num_workers=1)
        plant = MujocoSystem.from_task(controller.task, seed)
        noisy = NoisyLateState(
            plant, std, np.sqrt(2) * std * rate, rate, delay, np.random.default_rng([seed, 7])
        )
        with controller:
            state_estimator = make_estimator("state", controller.task, task_name=task_name)
            result = run_episode(
                controller, noisy, duration, latency, seed, estimator=state_estimator
            )  # type: ignore[arg-type]
    else:
        sensing = {
            "full state": Sensing(),
            "sensors + ekf": Sensing("sensors", **settings, estimator="ekf"),
            "sensors + ukf": Sensing("sensors", **settings, estimator="ukf"),
            "ekf, ideal sensors": Sensing("sensors", estimator="ekf"),
        }[mode]
        result = run_seeded_episode(
            EpisodeSpec(task_name, optimizer, duration, latency, sensing=sensing), seed
        )
    return next(iter(result.metrics.items()))


def has_single_rate(task_name: str) -> bool:
    """Whether the task's sensing is one noise, rate and delay for every sensor (the noisy-state
    baseline's)."""
    return all(not isinstance(value, dict) for value in SENSING.get(task_name, ENCODERS).values())


def quality_table(args: argparse.Namespace) -> None:
    """The closed-loop table of `args` (the command line's tasks, optimizer, seeds, duration,
    latency, modes)."""
    tasks, optimizer, duration = args.tasks, args.optimizer, args.duration
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    true_start, planner_noise, latency = args.true_start, args.planner_noise, args.latency_ms / 1000
    modes = (
        "full state",
        "sensors + ekf",
        "sensors + ukf",
        "state, noisy + late",
        "ekf, ideal sensors",
    )
    modes += ("ekf, ideal, true start",) if true_start else ()
    modes += ("state + planner noise",) if planner_noise > 0 else ()
    print(
        f"closed loop, seeds {seeds.start}-{seeds.stop - 1} x {duration:g} s, {optimizer}, "
        f"latency {args.latency_ms:g} "
        "ms; mean ± std over seeds; sensing per task:"
    )
    for task_name in tasks:
        print(f"  {task_name}: {SENSING.get(task_name, ENCODERS)}")
    print(
        "  ekf, ideal sensors: the same measured sensors without noise or delay, every plant "
        "step (the filter's own loss)"
    )
    if planner_noise > 0:
        print(
            "  state + planner noise: the true state every step, positions with std "
            f"{planner_noise:g}, no filter"
        )
    ratio_names = [RATIO_NAMES[m] for m in modes[1:]]
    print(
        f"{'task':16} {'metric':19} "
        + " ".join(f"{m:>20}" for m in modes)
        + " "
        + " ".join(f"{r:>10}" for r in ratio_names)
    )
    for task_name in tasks:
        runs = {
            mode: [
                episode(task_name, optimizer, seed, duration, mode, planner_noise, latency)
                for seed in seeds
            ]
            for mode in modes
            if mode != "state, noisy + late" or has_single_rate(task_name)
        }
        metric = runs["full state"][0][0]
        results = {mode: np.array([value for _, value in values]) for mode, values in runs.items()}
        cells = " ".join(
            f"{results[m].mean():>8.3f} ± {results[m].std():<9.3f}"
            if m in results
            else f"{'n/a':>20}"
            for m in modes
        )
        full = results["full state"].mean()
        ratios = [
            results[m].mean() / full if m in results and full else float("nan") for m in modes[1:]
        ]
        print(
            f"{task_name:16} {metric:19} {cells} " + " ".join(f"{r:>10.2f}" for r in ratios),
            flush=True,
        )


def leap_cube_cost(steps: int = 500) -> None:
    """The EKF's update time on leap_cube with docs/estimation.md's sensing, fresh and reused
    Jacobians, and the UKF's, with the estimate's error against the plant's true state for each
    (mean and 95th percentile over the steps)."""
    print(
        f"\nEKF and UKF on leap_cube, {steps} steps of a hand waving the cube: encoders 100 "
        "Hz; cube pose 30 Hz, 2 mm, 1 deg, "
        "40 ms late"
    )
    print(
        f"{'relinearize_every':>17} {'jacobians/update':>16} {'update ms':>10} {'in mj_steps':>12} "
        f"{'cube mm mean/p95':>17} {'cube deg mean/p95':>18} {'joints rad':>11}"
    )
    camera_error: list[float] = []
    for every in (1, 2, 4, "ukf"):
        controller_task = judo.get_registered_tasks()["leap_cube"][0]()
        plant = MujocoSystem.from_task(controller_task, 0)
        sensed = SensedSystem(plant, **LEAP_SENSING, rng=np.random.default_rng(0))  # type: ignore[arg-type]
        if every == "ukf":
            ekf = make_estimator("ukf", controller_task, UKFConfig(noise_framequat=np.deg2rad(1.0)))
        else:
            config = EKFConfig(relinearize_every=int(every), noise_framequat=np.deg2rad(1.0))
            ekf = make_estimator("ekf", controller_task, config)
        controls = ControlHistory(controller_task.nu)
        ekf.reset(sensed.read_state())
        home = controller_task.model.key_ctrl[0]
        rng = np.random.default_rng(1)
        walls, pos_err, rot_err, joint_err = [], [], [], []
        for k in range(steps):
            action = home + 0.15 * np.sin(0.05 * k + np.arange(16)) + 0.02 * rng.normal(size=16)
            controls.append(sensed.time, action)
            sensed.apply(action)
            sensed.step()
            reading = sensed.read_state()
            started = time.perf_counter()
            estimate = ekf.update(reading, sensed.time, controls)
            walls.append(time.perf_counter() - started)
            truth = plant.task.data.qpos
            pos_err.append(1e3 * np.linalg.norm(estimate.state[16:19] - truth[16:19]))
            rotation = np.zeros(3)
            mujoco.mju_subQuat(rotation, estimate.state[19:23], truth[19:23])
            rot_err.append(np.rad2deg(np.linalg.norm(rotation)))
            joint_err.append(np.abs(estimate.state[:16] - truth[:16]).mean())
            # the camera's own position as read (noisy, 40 ms old) against the cube's now
            if every == 1:
                camera_error.append(
                    1e3 * np.linalg.norm(reading.sensors[16:19] - plant.sensor_values()[16:19])
                )
        per_update = ekf.linearizations / steps  # type: ignore[attr-defined]
        skip = min(20, steps // 2)  # the first readings, while the filter converges
        median = float(np.median(walls[skip:]))
        position, rotation_deg = np.array(pos_err[skip:]), np.array(rot_err[skip:])
        print(
            f"{every:>17} {per_update:>16.2f} {1e3 * median:>10.2f} "
            f"{median / mj_step_seconds(controller_task.model):>12.0f} "
            f"{position.mean():>8.2f}/{np.percentile(position, 95):<8.2f} "
            f"{rotation_deg.mean():>8.2f}/{np.percentile(rotation_deg, 95):<9.2f} "
            f"{np.mean(joint_err[skip:]):>11.4f}",
            flush=True,
        )
    print(
        "the camera's position as read, against the cube's now: "
        f"{np.mean(camera_error[skip:]):.2f} mm mean"
    )
    print(
        "update ms is wall time on this machine; 'in mj_steps' divides it by one mj_step of the "
        "model here"
    )


def mj_step_seconds(model: mujoco.MjModel, repeats: int = 200) -> float:
    """Median wall time of one mj_step of `model` from its keyframe (the unit the EKF's cost is
    given in)."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    walls = []
    for _ in range(repeats):
        started = time.perf_counter()
        mujoco.mj_step(model, data)
        walls.append(time.perf_counter() - started)
    return float(np.median(walls))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--tasks", nargs="+", default=["cartpole", "pendulum"])
    parser.add_argument("--optimizer", default="mppi")
    parser.add_argument("--seeds", type=int, default=5, help="how many seeds")
    parser.add_argument(
        "--first-seed", type=int, default=0, help="the first seed (fresh seeds: 5 after 0-4)"
    )
    parser.add_argument(
        "--latency-ms", type=float, default=0.0, help="sim-time delay before a plan takes effect"
    )
    parser.add_argument("--duration", type=float, default=8.0)
    parser.add_argument(
        "--cost-only", action="store_true", help="print only the leap_cube EKF cost"
    )
    parser.add_argument(
        "--true-start",
        action="store_true",
        help="add the EKF with ideal sensors started from the true state",
    )
    parser.add_argument(
        "--planner-noise",
        type=float,
        default=0.0,
        metavar="STD",
        help="add the true state with this position noise (m or rad) every step, no filter",
    )
    parser.add_argument(
        "--cost-steps",
        type=int,
        default=500,
        help="plant steps of the leap_cube cost run (0: skip)",
    )
    args = parser.parse_args()
    if not args.cost_only:
        quality_table(args)
    if args.cost_steps > 0:
        leap_cube_cost(args.cost_steps)


if __name__ == "__main__":
    main()
