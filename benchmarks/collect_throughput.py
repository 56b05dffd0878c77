"""Throughput of `python -m judo collect`: episodes per minute and samples per second with 1 and 2
workers.

Each (task, workers) row runs `--episodes` episodes through the collect
driver (judo.collection.run.collect, the code the command runs) on one local Ray with max(--workers)
CPUs, after a warm-up round that starts the Ray workers; the scaling column is samples/s over
the 1-worker row's. The file size per 1000 samples is that of the row's HDF5 file. Run from the
repository root (needs the `collect` extra):

    PYTHONPATH=src python benchmarks/collect_throughput.py [--tasks cartpole leap_cube] [--workers 1 2]
"""  # noqa: E501

import contextlib
import io
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import tyro
from rich.console import Console
from rich.table import Table

from judo import ray_cluster as cluster
from judo.collection.collect import CollectArgs, env_args
from judo.collection.run import collect
from judo.evaluation.seeded import EpisodeSpec, configs_in_force


@dataclass
class Args:
    """Sizes of the collect throughput benchmark."""

    tasks: tuple[str, ...] = ("cartpole", "leap_cube")
    """Tasks to run."""
    optimizer: str = "ps"
    """Optimizer of every task."""
    workers: tuple[int, ...] = (1, 2)
    """Worker counts to compare (a local Ray with the largest)."""
    episodes: int = 8
    """Timed episodes per row."""
    duration: float = 5.0
    """Seconds of sim time per episode."""


def run(
    task: str, optimizer: str, workers: int, episodes: int, duration: float, out: Path
) -> float:
    """Collect `episodes` episodes into `out` with `workers` at once; returns the wall seconds."""
    args = CollectArgs(
        task, optimizer, out=out, episodes=episodes, duration=duration, workers=workers
    )
    spec = EpisodeSpec(task, optimizer, duration)
    started = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        collect(
            spec, env_args(args, configs_in_force(spec)), SimpleNamespace(**vars(args)), "", workers
        )
    return time.perf_counter() - started


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    cluster.start_ray(None, max(args.workers))
    table = Table(
        title=f"collect throughput, {args.optimizer}, {args.episodes} episodes x {args.duration:g} "
        f"s, {os.cpu_count()} cores"
    )
    for column in (
        "task",
        "workers",
        "episodes/min",
        "samples/s",
        "scaling",
        "KB per 1000 samples",
    ):
        table.add_column(column, justify="left" if column == "task" else "right")
    try:
        with tempfile.TemporaryDirectory() as folder:
            for task in args.tasks:
                run(
                    task,
                    args.optimizer,
                    max(args.workers),
                    max(args.workers),
                    args.duration,
                    Path(folder) / f"warm-{task}.h5",
                )
                base = None
                for workers in args.workers:
                    out = Path(folder) / f"{task}-{workers}.h5"
                    seconds = run(task, args.optimizer, workers, args.episodes, args.duration, out)
                    samples = args.episodes * round(args.duration / float(env_timestep(out)))
                    rate = samples / seconds
                    base = base or rate
                    size = out.stat().st_size / 1024 / samples * 1000
                    table.add_row(
                        task, str(workers), f"{60 * args.episodes / seconds:.1f}", f"{rate:.0f}",
                        f"{rate / base:.2f}x", f"{size:.0f}",
                    )  # fmt: skip
    finally:
        cluster.stop_ray()
    Console().print(table)


def env_timestep(path: Path) -> float:
    """The plant timestep recorded in a collect file's env_args."""
    import json

    import h5py

    with h5py.File(path, "r") as file:
        return json.loads(str(file["data"].attrs["env_args"]))["plant_timestep"]


if __name__ == "__main__":
    main()
