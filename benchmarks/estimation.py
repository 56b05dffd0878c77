"""Planning from what a robot measures (issue #22): closed-loop quality with sensors + EKF against the full
state, and the EKF's cost on leap_cube.

    PYTHONPATH=src python benchmarks/estimation.py                     # cartpole, pendulum: 5 seeds x 8 s
    PYTHONPATH=src python benchmarks/estimation.py --tasks acrobot --seeds 3 --duration 10
    PYTHONPATH=src python benchmarks/estimation.py --cost-only           # just the leap_cube EKF cost

Each task runs three ways on the same seeds (the plant's start state and the sensor noise are seeded):
- "full state": today's evaluate, the true [qpos, qvel] every step;
- "sensors + ekf": SensedSystem serving only the task's measured sensors (encoders: std 0.005 rad,
  100 Hz, 10 ms late) into the EKF, which fuses each reading at the time it was taken and predicts to now;
- "sensors, no filter": the same readings planned from as they come: positions as read and velocities by
  differencing successive readings, late values taken as current. The gap to the EKF is what the filter buys.
The metric is the task's first metric (cartpole: balanced_fraction, pendulum: upright_fraction), from the
true plant state. The episode's loop is judo.runtime.closed_loop.ClosedLoop, with the estimator between
the reading and the plan (`read`) and every served action kept for its predictions (`serve`).

The leap_cube cost: one EKF update (a finite-difference Jacobian of 2 nv = 44 state columns, ~45 mj_steps)
against one mj_step of the same model in the same process, so the ratio holds on a loaded machine, and the
wall time (which does not). With relinearize_every=k the Jacobians are reused for k steps.
"""

import argparse
import time

import mujoco
import numpy as np

import judo
from judo.core.estimator import ControlHistory, Estimator, EstimatorConfig, estimate_of
from judo.core.registry import make_controller, make_estimator
from judo.estimators.ekf import EKFConfig
from judo.evaluation.episode import EpisodeLogRecorder
from judo.runtime.closed_loop import ClosedLoop
from judo.runtime.sensing import SensedSystem
from judo.runtime.system import MujocoSystem, SystemState

SENSING = {"noise": 0.005, "rate": 100.0, "delay": 0.01}
"""The issue's encoder setting for cartpole, pendulum, acrobot and double_cartpole."""
LEAP_SENSING = {
    "noise": {"jointpos": 0.005, "framepos": 0.002, "framequat": np.deg2rad(1.0)},
    "rate": {"jointpos": 100.0, "framepos": 30.0, "framequat": 30.0},
    "delay": {"jointpos": 0.0, "framepos": 0.04, "framequat": 0.04},
}
"""The issue's leap_cube setting: encoders at 100 Hz, the cube's pose at 30 Hz, 2 mm and 1 degree, 40 ms late."""
SENSOR_STREAM = 0x73656E73
"""Second word of the sensor noise's seed sequence, apart from the plant's and the controller's."""


class Differencing(Estimator[EstimatorConfig]):
    """No filter: qpos from the joint encoders as read, qvel by differencing successive readings (for tasks
    whose measured sensors are one encoder per joint, in qpos order)."""

    def reset(self, reading: SystemState) -> None:
        self.previous: tuple[float, np.ndarray] | None = None
        self.velocity = np.zeros(self.task.model.nv)

    def update(self, reading: SystemState, time: float, controls: ControlHistory) -> SystemState:
        positions = np.asarray(reading.sensors, dtype=float)
        if self.previous is not None and reading.time > self.previous[0] + 1e-9:
            self.velocity = (positions - self.previous[1]) / (reading.time - self.previous[0])
        if self.previous is None or reading.time > self.previous[0] + 1e-9:
            self.previous = (reading.time, positions.copy())
        return estimate_of(reading, np.concatenate([positions, self.velocity]), time)


def episode(task_name: str, optimizer: str, seed: int, duration: float, mode: str) -> tuple[str, float]:
    """(name, value) of the task's first metric in one seeded episode, planned from the full state, the EKF or
    no filter."""
    controller = make_controller(task_name, optimizer, seed=seed, num_workers=1)
    plant = MujocoSystem.from_task(controller.task, seed)
    num_steps = max(1, round(duration / plant.timestep))
    model = plant.task.sim_model
    recorder = EpisodeLogRecorder(controller.task, (model.nq, model.nv, model.nu, model.nsensordata), num_steps)
    if mode == "full state":
        loop = ClosedLoop(controller, plant, recorders=[recorder])
    else:
        rng = np.random.default_rng([seed, SENSOR_STREAM])
        sensed = SensedSystem(plant, **SENSING, rng=rng)  # type: ignore[arg-type]
        estimator = (
            make_estimator("ekf", controller.task, task_name=task_name)
            if mode == "sensors + ekf"
            else Differencing(controller.task)
        )
        loop = ClosedLoop(controller, sensed, recorders=[recorder], estimator=estimator)  # logs the true state
    loop.restart()
    for _ in range(num_steps):
        loop.step()
    controller.close()
    name, value = next(iter(plant.task.metrics(recorder.log).items()))
    return name, value


def quality_table(tasks: list[str], optimizer: str, seeds: int, duration: float) -> None:
    modes = ("full state", "sensors + ekf", "sensors, no filter")
    print(f"closed loop, {seeds} seeds x {duration:g} s, {optimizer}; encoders std 0.005 rad, 100 Hz, 10 ms late")
    print(f"{'task':16} {'metric':18} " + " ".join(f"{m:>20}" for m in modes) + f" {'ekf / full':>11}")
    for task_name in tasks:
        runs = {m: [episode(task_name, optimizer, s, duration, m) for s in range(seeds)] for m in modes}
        metric = runs["full state"][0][0]
        results = {m: [value for _, value in v] for m, v in runs.items()}
        means = {m: float(np.mean(v)) for m, v in results.items()}
        cells = " ".join(f"{means[m]:>8.3f} ± {np.std(results[m]):<9.3f}" for m in modes)
        ratio = means["sensors + ekf"] / means["full state"] if means["full state"] else float("nan")
        print(f"{task_name:16} {metric:18} {cells} {ratio:>11.2f}", flush=True)


def leap_cube_cost(steps: int = 500) -> None:
    """The EKF's update time on leap_cube with the issue's sensing, fresh and reused Jacobians, and the
    estimate's error against the plant's true state for each (mean and 95th percentile over the steps)."""
    print(
        f"\nEKF on leap_cube, {steps} steps of a hand waving the cube: encoders 100 Hz; cube pose 30 Hz, 2 mm, 1 deg, "
        "40 ms late"
    )
    print(
        f"{'relinearize_every':>17} {'jacobians/update':>16} {'update ms':>10} {'in mj_steps':>12} "
        f"{'cube mm mean/p95':>17} {'cube deg mean/p95':>18} {'joints rad':>11}"
    )
    camera_error: list[float] = []
    for every in (1, 2, 4):
        controller_task = judo.get_registered_tasks()["leap_cube"][0]()
        plant = MujocoSystem.from_task(controller_task, 0)
        sensed = SensedSystem(plant, **LEAP_SENSING, rng=np.random.default_rng(0))  # type: ignore[arg-type]
        config = EKFConfig(relinearize_every=every, noise_framequat=np.deg2rad(1.0))
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
            if every == 1:  # the camera's own position as read (noisy, 40 ms old) against the cube's now
                camera_error.append(1e3 * np.linalg.norm(reading.sensors[16:19] - plant.sensor_values()[16:19]))
        per_update = ekf.linearizations / steps  # type: ignore[attr-defined]
        skip = min(20, steps // 2)  # the first readings, while the filter converges
        median = float(np.median(walls[skip:]))
        position, rotation_deg = np.array(pos_err[skip:]), np.array(rot_err[skip:])
        print(
            f"{every:>17} {per_update:>16.2f} {1e3 * median:>10.2f} {median / mj_step_seconds(controller_task.model):>12.0f} "
            f"{position.mean():>8.2f}/{np.percentile(position, 95):<8.2f} "
            f"{rotation_deg.mean():>8.2f}/{np.percentile(rotation_deg, 95):<9.2f} {np.mean(joint_err[skip:]):>11.4f}",
            flush=True,
        )
    print(f"the camera's position as read, against the cube's now: {np.mean(camera_error[skip:]):.2f} mm mean")
    print("update ms is wall time on this machine; 'in mj_steps' divides it by one mj_step of the model here")


def mj_step_seconds(model: mujoco.MjModel, repeats: int = 200) -> float:
    """Median wall time of one mj_step of `model` from its keyframe (the unit the EKF's cost is given in)."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    walls = []
    for _ in range(repeats):
        started = time.perf_counter()
        mujoco.mj_step(model, data)
        walls.append(time.perf_counter() - started)
    return float(np.median(walls))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", nargs="+", default=["cartpole", "pendulum"])
    parser.add_argument("--optimizer", default="mppi")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--duration", type=float, default=8.0)
    parser.add_argument("--cost-only", action="store_true", help="print only the leap_cube EKF cost")
    parser.add_argument("--cost-steps", type=int, default=500, help="plant steps of the leap_cube cost run (0: skip)")
    args = parser.parse_args()
    if not args.cost_only:
        quality_table(args.tasks, args.optimizer, args.seeds, args.duration)
    if args.cost_steps > 0:
        leap_cube_cost(args.cost_steps)


if __name__ == "__main__":
    main()
