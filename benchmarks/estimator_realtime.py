"""The app's real-time factor with a filter between the sensors and the plan.

Starts the real App headless (no GUI) on each task with `observe="sensors"` and each filter, lets it
run `--warmup` s, then measures `--duration` s of wall time: the real-time factor (sim seconds per
wall second, 1 = real time), the planning rate, and, where the estimator runs on a thread of its
own, how far its newest estimate lagged behind the plant (mean and max, in ms of sim time) and how
often it started over to catch up (`EstimatorThread.catch_ups`). A "state" row (the full state, no
filter) gives each task's figure without one. Each filter runs twice in a row, at the same load: on
the plant thread (the App's EstimatorThread unwrapped) and on its own thread (the app's default).
Run from the repository root:

    PYTHONPATH=src python benchmarks/estimator_realtime.py
    PYTHONPATH=src python benchmarks/estimator_realtime.py --tasks walker --filters ukf --duration 15

The load average (/proc/loadavg) is printed before and after each row: on a machine shared with
other work the figures drop with it, so compare rows taken at the same load.
"""  # noqa: E501

import time
from dataclasses import dataclass

import tyro

from judo.runtime.app import App
from judo.runtime.running.estimator_thread import EstimatorThread


@dataclass
class Args:
    """Tasks, filters and durations of the real-time benchmark."""

    tasks: tuple[str, ...] = ("walker", "leap_cube")
    """Tasks to run."""
    filters: tuple[str, ...] = ("state", "ekf", "ukf")
    """Estimators to run with observe="sensors"; "state" runs the full state with no filter."""
    optimizer: str = "mppi"
    """Optimizer to plan with (the CLI's default)."""
    duration: float = 12.0
    """Wall seconds measured per row."""
    warmup: float = 3.0
    """Wall seconds run before measuring (the first reading, the first plans)."""
    num_workers: int | None = None
    """Rollout threads (the number of cores by default, as in the app)."""
    seed: int = 0
    """Seeds the optimizer, the plant and the sensor noise."""
    threads: tuple[str, ...] = ("plant", "own")
    """Where each filter runs: "plant" (on the plant thread) and/or "own" (its own thread)."""


def load() -> str:
    """The 1-, 5- and 15-minute load averages."""
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def measure(task: str, estimator: str, thread: str, args: Args) -> dict[str, str]:
    """One row: run the app on `task` with `estimator` on `thread` and return its figures,
    formatted."""
    sensing = {} if estimator == "state" else {"observe": "sensors", "estimator": estimator}
    app = App(
        task, args.optimizer, gui=False, seed=args.seed, num_workers=args.num_workers, **sensing
    )  # type: ignore[arg-type]
    loop = app.session.closed_loop
    if thread == "plant" and isinstance(loop.estimator, EstimatorThread):
        loop.estimator = loop.estimator.estimator  # the filter itself, called on the plant thread
    load_before = load()
    app.start()
    lags: list[float] = []
    try:
        time.sleep(args.warmup)
        sim0, plans0, wall0 = app.stats.sim_time(), app.stats.num_plans(), time.perf_counter()
        # sample the filter's lag at 20 Hz meanwhile
        while time.perf_counter() < wall0 + args.duration:
            time.sleep(0.05)
            # a filter on a thread of its own
            lag = getattr(app.session.closed_loop.estimator, "lag", None)
            if lag is not None:
                lags.append(1e3 * lag)
        sim1, plans1, wall1 = app.stats.sim_time(), app.stats.num_plans(), time.perf_counter()
        status = app.status.message
        catch_ups = getattr(app.session.closed_loop.estimator, "catch_ups", None)
    finally:
        app.stop()
    wall = wall1 - wall0
    return {
        "task": task,
        "estimator": estimator,
        "filter thread": "-" if estimator == "state" else thread,
        "real-time factor": f"{(sim1 - sim0) / wall:.3f}",
        "plans / s": f"{(plans1 - plans0) / wall:.1f}",
        "filter lag ms (mean / max)": f"{sum(lags) / len(lags):.0f} / {max(lags):.0f}"
        if lags
        else "-",
        "catch-ups": "-" if catch_ups is None else str(catch_ups),
        "load before / after": f"{load_before} / {load()}",
        "status": status[:60],
    }


def main(args: Args) -> None:
    print(f"load average at the start: {load()}  (1, 5, 15 min)")
    runs = [
        (t, e, "-" if e == "state" else h)
        for t in args.tasks
        for e in args.filters
        for h in args.threads
    ]
    rows = [measure(*run, args) for run in dict.fromkeys(runs)]  # one "state" row per task
    columns = list(rows[0])
    widths = {c: max(len(c), *(len(str(r[c])) for r in rows)) for c in columns}
    print(" | ".join(c.ljust(widths[c]) for c in columns))
    print("-+-".join("-" * widths[c] for c in columns))
    for row in rows:
        print(" | ".join(str(row[c]).ljust(widths[c]) for c in columns))


if __name__ == "__main__":
    main(tyro.cli(Args))
