"""Episodes of the app itself (wall time, no GUI) scored by the task's own metrics: what `evaluate`
measures in sim time, here with the app's real planning latency (a plan is served once its cycle is
done).

    PYTHONPATH=src python benchmarks/app_episode.py --task cartpole --control-freq 5 --seeds 11 12 13 \\
        [--iterations-per-second 0] [--latency-compensation | --no-latency-compensation] [--feedback | --no-feedback] [--seconds 15]

Each seed starts an App on the task's defaults with the given overrides, lets it run `--seconds` of
wall time, samples the plant's state from the app's own snapshots (every 20 ms, each new reading
once), rebuilds the sensors on the task's plant model and prints `Task.metrics` of that log, with
the plans made and the optimizer iterations a cycle ran (the app's deadline may cut the extra ones
of `iterations_per_second`). The figures depend on the machine and its load: compare settings in one
run, on an idle machine.
"""  # noqa: E501

import argparse
import dataclasses
import time

import mujoco
import numpy as np

import judo
from judo.core.configuration.registry import make_config
from judo.core.task import EpisodeLog
from judo.runtime.app import App


def episode(
    task: str, optimizer: str, config: judo.ControllerConfig, seed: int, seconds: float
) -> str:
    """One app episode of `seconds` wall seconds: a line with its plans, iterations and the task's
    metrics."""
    app = App(task, optimizer, controller_config=config, gui=False, seed=seed)
    app.start()
    rows: list[tuple[float, np.ndarray]] = []
    iterations: list[int] = []
    try:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            snapshot = app.buffer.latest("system")
            if snapshot is not None:
                reading = snapshot.value.reading
                if not rows or reading.time > rows[-1][0]:
                    rows.append((reading.time, np.array(reading.state)))
            iterations.append(app.controller.iterations_run)
            time.sleep(0.02)
        plans = app.stats.num_plans()
    finally:
        app.stop()
    planning = app.controller.task
    model = planning.sim_model
    data = mujoco.MjData(model)
    sensors = []
    for _, state in rows:  # the metrics read sensors: rebuild them on the plant's model
        data.qpos[:], data.qvel[:] = state[: model.nq], state[model.nq :]
        mujoco.mj_forward(model, data)
        sensors.append(data.sensordata.copy())
    log = EpisodeLog(
        times=np.array([t for t, _ in rows]),
        states=np.stack([s for _, s in rows]),
        controls=np.zeros((len(rows), planning.nu)),
        sensors=np.stack(sensors),
    )
    metrics = ", ".join(f"{name} {value:.2f}" for name, value in planning.metrics(log).items())
    sim = log.times[-1] - log.times[0]
    return (
        f"seed {seed}: {sim:.1f} s of sim in {seconds:g} s, {plans} plans, iterations a "
        "cycle median "
        f"{np.median(iterations):g} (max {max(iterations)}); {metrics}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="cartpole")
    parser.add_argument("--optimizer", default="mppi")
    parser.add_argument("--control-freq", type=float, help="Hz (default: the task's)")
    parser.add_argument("--iterations-per-second", type=float, help="default: the task's (20)")
    parser.add_argument(
        "--latency-compensation",
        action=argparse.BooleanOptionalAction,
        help="default: the task's own setting",
    )
    parser.add_argument(
        "--feedback", action=argparse.BooleanOptionalAction, help="default: the task's own setting"
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[11, 12, 13])
    parser.add_argument("--seconds", type=float, default=15.0, help="wall seconds per episode")
    args = parser.parse_args()
    overrides = {
        "control_freq": args.control_freq,
        "iterations_per_second": args.iterations_per_second,
        "latency_compensation": args.latency_compensation,
        "feedback": args.feedback,
    }
    config = make_config(judo.ControllerConfig, args.task)
    config = dataclasses.replace(config, **{k: v for k, v in overrides.items() if v is not None})
    print(
        f"{args.task} with {args.optimizer} in the app: control_freq {config.control_freq:g} Hz, "
        f"iterations_per_second {config.iterations_per_second:g}, latency_compensation "
        f"{config.latency_compensation}, "
        f"feedback {config.feedback}"
    )
    for seed in args.seeds:
        print(episode(args.task, args.optimizer, config, seed, args.seconds), flush=True)


if __name__ == "__main__":
    main()
