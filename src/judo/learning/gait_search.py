"""`python -m judo gait-search`: teach a legged task (quadruped_velocity's quadruped, or go2_walk's
Go2) a locomotion policy by policy search, and write it as ONNX and as the JSON file judo's numpy
`GaitPolicy` reads.

python -m judo gait-search --out quadruped_locomotion.onnx
python -m judo evaluate --task quadruped_velocity --policy quadruped_locomotion.onnx --seeds 5 --first-seed 1000
python -m judo gait-search --task go2_walk --out go2_trot.onnx
python -m judo gait-search --task g1_stand --out g1_balance.onnx  (with the settings docs/tasks.md gives)
"""  # noqa: E501

import json
import shlex
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import tyro

from judo.cli_shared import fail, optional_pyplot, output_console, parse_args, progress_display
from judo.core.commandline.boundary import check_output_file
from judo.core.configuration.config import require
from judo.core.errors import JudoError
from judo.learning.policy_search import (
    EVERY,
    GaitProblem,
    GaitSearchSettings,
    Iteration,
    go2_problem,
    quadruped_problem,
)
from judo.tasks.gait_policy import GaitLayout
from judo.tasks.unitree import g1

DESCRIPTION = (
    "Teach a legged task (--task quadruped_velocity, the default, or go2_walk) a locomotion "
    "policy for commands [vx, vy, yaw rate] by policy search: judo's CEM tunes a gait policy (a "
    "trot's clock harmonics, shaped linearly by the command, plus feedback on the trunk's gyro "
    "and tilt; judo.tasks.gait_policy) on closed-loop episodes scored by the task's own reward, "
    "or (--task g1_stand) the G1's balance policy (the standing pose plus feedback on the "
    "pelvis's gyro, tilt and velocity) on episodes that start with a kick, "
    "the objective its MPC plans with. Writes an ONNX file for --policy and quadruped_navigate, "
    "the same policy as JSON beside it (OUT.json, what judo.tasks.gait_policy.GaitPolicy runs in "
    "numpy: go2_walk's proposals), and the reward curve as a PNG (with matplotlib). The files "
    "hold the best iteration's mean; Ctrl-C ends the search early and writes the best so far "
    "(exit 130)."
)
SEARCH_PNG = ".search.png"
"""The reward curve's file name beside --out: OUT.search.png."""
GaitTaskName = Literal["quadruped_velocity", "go2_walk", "g1_stand"]


def g1_problem(task: g1.G1Stand | None = None) -> GaitProblem:
    """g1_stand: from the standing pose (keyframe "home"), each episode kicked (g1.draw_kick: its
    "command" is the pelvis's start velocity), scored by g1_stand's reward; the balance policy
    (g1.balance_layout) starts at g1.ankle_and_hip_strategy and tunes g1.balance_parameters: the
    legs' and waist's offsets and feedback gains."""
    task = g1.G1Stand(policy_path=None) if task is None else task
    layout, nq = g1.balance_layout(task.home_ctrl), task.model.nq
    return GaitProblem(
        name="g1_stand",
        task=task,
        layout=layout,
        start_qpos=task.model.key_qpos[task.home_key].copy(),
        start_ctrl=task.home_ctrl.copy(),
        draw=g1.draw_kick,
        observe=lambda commands, states, times, out: g1.balance_features(states, nq, out),
        reward=lambda states, sensors, ctrl, _: task.reward(states, sensors, ctrl, task.config),
        fallen_height=g1.FALL_HEIGHT,
        kicks=True,
        free=g1.balance_parameters(layout),
        initial=g1.ankle_and_hip_strategy(layout),
    )


PROBLEMS = {
    "quadruped_velocity": quadruped_problem,
    "go2_walk": go2_problem,
    "g1_stand": g1_problem,
}
"""The tasks gait-search teaches, by name: the two gaits (judo.learning.policy_search) and
g1_stand's balance."""


@dataclass
class GaitSearchArgs(GaitSearchSettings):
    """Arguments of `python -m judo gait-search`: the search's settings and the file to write."""

    out: Annotated[Path, tyro.conf.arg(metavar="POLICY.onnx")] = field(kw_only=True)
    """The ONNX file to write (the same policy goes beside it as POLICY.json, its reward curve as
    POLICY.search.png)."""
    task: GaitTaskName = "quadruped_velocity"
    """The task whose reward, start and commands the search walks (PROBLEMS)."""
    overwrite: bool = False
    """Replace an --out file that exists (without it, gait-search refuses before searching)."""

    def validate(self) -> None:
        super().validate()
        require(self.out.suffix == ".onnx", f"--out must name an .onnx file, got {str(self.out)!r}")
        check_output_file("--out", self.out, (self.out.stem + SEARCH_PNG, self.out.stem + ".json"))
        require(
            self.overwrite or not self.out.exists(),
            f"--out {str(self.out)!r} exists; give --overwrite to replace it, or another --out",
        )


def write_gait_policy(
    out: Path, parameters: np.ndarray, layout: GaitLayout, metadata: dict[str, str]
) -> Path:
    """Write the gait policy of (P,) `parameters` on `layout` to `out` through a temporary file (no
    half file on failure)."""
    from judo.core.policies.onnx_policy import save_model
    from judo.learning.gait_policy import gait_policy_model

    return save_model(out, gait_policy_model(parameters, layout, metadata), JudoError)


def write_gait_json(
    out: Path, parameters: np.ndarray, layout: GaitLayout, metadata: dict[str, str]
) -> Path:
    """Write the same policy as `GaitPolicy`'s JSON file beside `out` (OUT.json); returns its
    path."""
    from judo.tasks.gait_policy import save_gait_policy

    return save_gait_policy(out.with_suffix(".json"), parameters, layout, metadata)


def plot_search(path: Path, history: list[Iteration], task: str) -> Path | None:
    """The mean's and the best candidate's reward per iteration as a PNG at `path`; None without
    matplotlib."""
    plt = optional_pyplot()
    if plt is None:
        return None
    figure, axes = plt.subplots(figsize=(6, 3.5), dpi=110)
    index = [record.index + 1 for record in history]
    axes.plot(index, [record.mean_reward for record in history], label="the CEM's mean")
    axes.plot(index, [record.best_reward for record in history], label="best candidate", alpha=0.6)
    axes.set_xlabel("iteration")
    axes.set_ylabel(f"{task} reward (higher is better)")
    axes.set_title("gait-search: reward on each iteration's drawn commands", fontsize=9)
    axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path)
    plt.close(figure)
    return path


def run(args: GaitSearchArgs, command: str) -> int:
    """Search with a progress bar, then write the ONNX file (the best iteration's mean) and its
    reward curve, and say how to use them. Returns the exit status: 0, or 130 when Ctrl-C ended the
    search (the best so far is written all the same)."""
    from rich.progress import BarColumn, TextColumn, TimeElapsedColumn

    from judo.learning.policy_search import search_gait
    from judo.tasks.quadruped_velocity import OBSERVATION
    from judo.tasks.unitree.go2 import OBSERVATION as GO2_OBSERVATION

    observations = {"go2_walk": GO2_OBSERVATION, "g1_stand": g1.OBSERVATION}

    console = output_console()
    settings = GaitSearchSettings(
        **{name: getattr(args, name) for name in asdict(GaitSearchSettings())}
    )
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
    )
    with progress_display(*columns, TimeElapsedColumn()) as progress:
        bar = progress.add_task("searching", total=args.iterations)

        def show(record: Iteration) -> None:
            text = (
                f"reward {record.mean_reward:.3f} (best {record.best_reward:.3f}), falls "
                f"{record.falls:.0%}"
            )
            progress.update(bar, completed=record.index + 1, description=text)

        problem = PROBLEMS[args.task]()
        result = search_gait(problem, settings, show)
    history, best = result.history, result.history[result.best_index]
    task, layout = problem.task, problem.layout
    metadata = {
        "name": args.out.stem,
        "task": args.task,
        "kind": "action",
        "head": "gait",
        "observation": observations.get(args.task, OBSERVATION),
        "observation_size": str(layout.observation_size),
        "control_freq": repr(1.0 / (EVERY * float(task.model.opt.timestep))),
        "training_command": command,
        "training_seconds": f"{history[-1].seconds:.1f}",
        "search": json.dumps(
            {
                **asdict(settings),
                "iterations_run": len(history),
                "best_iteration": best.index + 1,
                "best_reward": best.mean_reward,
                "final_reward": history[-1].mean_reward,
            }
        ),
    }
    write_gait_policy(args.out, result.parameters, layout, metadata)
    written = write_gait_json(args.out, result.parameters, layout, metadata)
    plot = plot_search(args.out.with_name(args.out.stem + SEARCH_PNG), history, args.task)
    stopped = "interrupted: " if result.interrupted else ""
    console.print(
        f"{stopped}wrote {args.out} and {written}, the mean of iteration {best.index + 1}, the "
        f"best of {len(history)} in "
        f"{history[-1].seconds / 60:.1f} min: the mean's reward {history[0].mean_reward:.3f} -> "
        f"{best.mean_reward:.3f} (last {history[-1].mean_reward:.3f}), falls {best.falls:.0%}"
        + (f"; the reward curve is {plot}" if plot else ""),
        soft_wrap=True,
    )
    console.print(
        f"score it on fresh seeds: python -m judo evaluate --task {args.task} --policy {args.out} "
        "--seeds 5 --first-seed 1000",
        soft_wrap=True,
    )
    return 130 if result.interrupted else 0


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo gait-search` on `argv` (sys.argv[1:] when None); exits with status 2 on
    bad arguments."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(GaitSearchArgs, argv, "python -m judo gait-search", DESCRIPTION)
    try:
        args.validate()
        from judo.core.errors import import_extra

        import_extra("onnx", "python -m judo gait-search", "policy")
        return run(args, "python -m judo gait-search " + shlex.join(argv))
    except JudoError as err:
        fail(str(err))
