"""Where a low-level policy's tick goes: the Python of one worker's block per tick, in thread CPU
time.

A worker of a low-level rollout (judo.core.rollouts.low_level, core/rollouts/stepper.py) runs, per
tick of k physics steps, its block's observation, one batched `act`, the copies into MuJoCo's inputs
and out of its outputs, then the physics
(`mujoco.rollout`, which releases the GIL). Everything but the physics and onnxruntime's run holds
the GIL while the other worker steps its rollouts. For each task, on one worker and its block of B
rows (the block of one of two workers at N = 2 B), from the task's start state, timed interleaved in
one process:
  - Python per tick: the low-level rollout of B x T steps, minus the same physics replayed tick by
    tick from the very states and ctrl the rollout took (`RolloutPool.rollout_block`, one call per
    tick), per tick (its minimum is the rollout's least minus the replay's least);
  - observation: `LowLevel.observe` of the block into its buffer;
  - act: the policy's `checked_act` on the block's observations (onnxruntime's run included, which
    holds no GIL).
Medians and minima of `--rounds` rounds (the minima are the steadier figure on a loaded machine).
The script runs on any commit since the stepper (`PolicyStepper`), so before and after compare with
PYTHONPATH alone.

    PYTHONPATH=src python benchmarks/low_level_ticks.py [--tasks quadruped_navigate cartpole_pd] [--rounds 15]
"""  # noqa: E501

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import tyro
from rich.console import Console
from rich.table import Table

from judo.core.configuration.registry import make_task
from judo.core.errors import JudoError
from judo.core.rollouts.low_level_rollout import LowLevelRollout
from judo.core.rollouts.rollout import RolloutPool
from judo.evaluation.timing import rollout_start
from judo.loop.system import MujocoSystem


@dataclass
class Args:
    """What to time and how often."""

    tasks: list[str] = field(default_factory=lambda: ["quadruped_navigate", "cartpole_pd"])
    """Tasks with a low-level policy (`Task.low_level`), by registered name."""
    rows: list[int] = field(default_factory=lambda: [4, 32])
    """B, the block's rows, one per task (the issue's N = 8 and N = 64 on two workers)."""
    num_steps: int = 100
    """T, physics steps per rollout."""
    rounds: int = 15
    """Timed rounds of each measurement, interleaved, after one untimed."""
    repeats: int = 10
    """Rollouts (and the same number of ticks' observations and acts) per round."""


class ReplayPool(RolloutPool):
    """A one-worker pool that keeps each tick's initial states and inputs while `log` is a list."""

    log: list[tuple[np.ndarray, np.ndarray]] | None = None

    def rollout_block(self, block, initial_states, inputs, control_spec, states, sensors) -> None:
        if self.log is not None:
            self.log.append((initial_states.copy(), inputs.copy()))
        super().rollout_block(block, initial_states, inputs, control_spec, states, sensors)


def cpu_us(call: Callable[[], object], repeats: int) -> float:
    """Thread CPU time (us) of `repeats` calls."""
    started = time.thread_time()
    for _ in range(repeats):
        call()
    return 1e6 * (time.thread_time() - started)


def measure(task_name: str, rows: int, args: Args) -> dict[str, list[float]]:
    """Per-tick thread CPU times (us) of each round: tick, observation, act."""
    try:
        task = make_task(task_name)
    except JudoError as err:
        raise SystemExit(str(err)) from None  # names the valid tasks
    low, model = task.low_level(), task.model
    if low is None:
        raise SystemExit(
            f"task {task_name!r} declares no low-level policy; expected cartpole_pd, "
            "quadruped_navigate, ..."
        )
    pool = ReplayPool(model, 1)
    backend = LowLevelRollout(pool, low)
    reading = MujocoSystem.from_task(task, 0).read_state()
    assert reading.state is not None, f"task {task_name!r}'s plant gives no state"
    initial, mocap = rollout_start(model, reading.state, reading.time, reading.metadata)
    rng = np.random.default_rng(0)
    commands = rng.uniform(*low.command_range.T, size=(rows, args.num_steps, low.command_size))
    pool.log = []
    states, _ = backend.rollout(initial, commands, mocap)
    log, pool.log = pool.log, None
    stepper = backend._stepper
    outputs = [
        (np.zeros((rows, n, stepper.nstate)), np.zeros((rows, n, model.nsensordata)))
        for n in stepper.states
    ]
    by_length = dict(zip(stepper.states, outputs, strict=True))

    def replay() -> None:
        for initial_states, inputs in log:
            pool.rollout_block(
                0, initial_states, inputs, stepper.control_spec, *by_length[inputs.shape[1]]
            )

    # one tick's arguments, as the rollout hands them: the block's states at a tick half way through
    tick = len(log) // 2
    current = log[tick][0]
    num_state = 1 + model.nq + model.nv
    previous = rng.normal(size=(rows, low.policy.action_size))
    buffer = np.zeros((rows, low.policy.observation_size))
    observed = (
        commands[:, tick * low.every],
        current[:, 1:num_state],
        previous,
        current[:, 0],
        buffer,
    )
    observations = np.array(low.observe(*observed), dtype=float)
    calls = {
        "rollout": lambda: backend.rollout(initial, commands, mocap),
        "replay": replay,
        "observation": lambda: low.observe(*observed),
        "act": lambda: low.policy.checked_act(observations, require_finite=False),
    }
    ticks = len(log)
    times: dict[str, list[float]] = {name: [] for name in calls}
    for round_ in range(args.rounds + 1):
        for name, call in calls.items():
            repeats = args.repeats * (ticks if name in ("observation", "act") else 1)
            value = cpu_us(call, repeats) / (args.repeats * ticks)
            if round_:
                times[name].append(value)
    pool.close()
    tick = [a - b for a, b in zip(times["rollout"], times["replay"], strict=True)]
    return {
        "tick": tick,
        "tick_min": [min(times["rollout"]) - min(times["replay"])],
        "observation": times["observation"],
        "act": times["act"],
        "physics": times["replay"],
        "ticks": [float(ticks)],
        "finite": [float(np.isfinite(states).all())],
    }


def cell(figures: dict[str, list[float]], name: str) -> str:
    """ "median / min" of one measurement's rounds (us)."""
    values = np.array(figures[name])
    # the rollout's least minus the replay's
    least = figures["tick_min"][0] if name == "tick" else values.min()
    return f"{np.median(values):.1f} / {least:.1f}"


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    if len(args.rows) != len(args.tasks):
        raise SystemExit(
            f"--rows needs one block size per task: {len(args.tasks)} tasks, got "
            f"{len(args.rows)} sizes"
        )
    table = Table(
        title="a low-level tick's Python, one worker's block, thread CPU time (median / min of "
        f"{args.rounds})"
    )
    for column in (
        "task",
        "B x T",
        "ticks",
        "physics us / tick",
        "Python us / tick",
        "observation us",
        "act us",
    ):
        table.add_column(column, justify="left" if column == "task" else "right")
    for task_name, rows in zip(args.tasks, args.rows, strict=True):
        figures = measure(task_name, rows, args)
        assert figures["finite"] == [1.0], f"{task_name}: the rollout went non-finite"

        table.add_row(
            task_name,
            f"{rows} x {args.num_steps}",
            f"{int(figures['ticks'][0])}",
            cell(figures, "physics"),
            cell(figures, "tick"),
            cell(figures, "observation"),
            cell(figures, "act"),
        )
    Console(width=160).print(table)


if __name__ == "__main__":
    main()
