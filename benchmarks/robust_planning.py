"""Planning under randomized models against a plant that differs from the planning model.

For each optimizer and each setting (num_randomizations x risk), runs closed-loop episodes on a
mismatched plant and prints the task's metrics and the median plan time (one control update):

- leap_cube: the plant's model overrides every contact's friction to 0.9 (the planner has 0.7 to 1.2
  per pair): --plant-overrides "opt.o_friction=[0.9, 0.9, 0.02, 0.0001, 0.0001]" by default, what
  the app, evaluate and collect take (the same model as leap_cube_plant.xml, bit for bit); any other
  FIELD.ELEMENT=VALUE works.
- fr3_pick: the plant's object is heavier and slipperier than the planner's (--mass-scale,
  --friction-scale on the object's body mass and inertia and its geom's friction).

The controller is the task's default, with --controller settings changed only by the row's
num_randomizations and risk; the randomized models come from the task's `randomize_model` hook.

    PYTHONPATH=src python benchmarks/robust_planning.py --task leap_cube --optimizers cem mppi \\
        --randomizations 1 4 --risks average cvar --seeds 3 --duration 60 [--backend warp --num-rollouts 1024]
"""  # noqa: E501

import argparse
import copy
import time

import mujoco
import numpy as np

import judo
from judo.core.configuration.config import with_updates
from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.model_override_checks import check_model_overrides
from judo.core.configuration.model_overrides import override_task_models, parse_override_entries
from judo.core.configuration.registry import lookup_optimizer, make_config
from judo.core.rollouts.risk import RISK_MEASURES
from judo.core.task import Task
from judo.evaluation.episode import run_episode
from judo.loop.system import PLANT_STREAM, MujocoSystem
from judo.tasks.fr3_pick import FR3Pick
from judo.tasks.leap_cube import LeapCube

LEAP_CUBE_PLANT = ("opt.o_friction=[0.9, 0.9, 0.02, 0.0001, 0.0001]",)
"""leap_cube's default --plant-overrides: every contact's friction 0.9, as leap_cube_plant.xml."""
HEADLINE = {
    "leap_cube": ("goals_per_minute", "drops"),
    "fr3_pick": ("success", "final_distance", "time_to_place"),
}
"""The metrics each task's table shows."""


def mismatched_plant(
    task: str, seed: int, mass_scale: float, friction_scale: float, overrides: tuple[str, ...]
) -> Task:
    """The plant task for `task`, seeded like `MujocoSystem.from_task`, reset to its start state."""
    if task == "leap_cube":
        plant: Task = LeapCube()
        override_task_models(
            plant, {}, check_model_overrides(plant.sim_model, parse_override_entries(overrides))
        )
    else:
        plant = FR3Pick()
        model = copy.deepcopy(plant.model)
        body = model.body("object").id
        model.body_mass[body] *= mass_scale
        model.body_inertia[body] *= mass_scale
        model.geom_friction[model.geom("object").id, 0] *= friction_scale
        mujoco.mj_setConst(model, mujoco.MjData(model))
        plant.sim_model, plant.data = model, mujoco.MjData(model)
    plant.rng = np.random.default_rng([seed, PLANT_STREAM])
    return plant


def run_setting(
    args: argparse.Namespace, optimizer: str, num_models: int, risk: str
) -> dict[str, float]:
    """Mean metrics and median plan time (ms) of one setting over the seeds."""
    rows, plan_ms = [], []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        settings = {"num_randomizations": num_models, "risk": risk, "cvar_alpha": args.cvar_alpha}
        controller_config = with_updates(
            make_config(ControllerConfig, args.task, optimizer), settings
        )
        optimizer_config = make_config(lookup_optimizer(optimizer)[1], args.task)
        if args.num_rollouts is not None:
            optimizer_config = with_updates(optimizer_config, {"num_rollouts": args.num_rollouts})
        controller = judo.make_controller(
            args.task,
            optimizer,
            controller_config=controller_config,  # type: ignore[arg-type]
            optimizer_config=optimizer_config,  # type: ignore[arg-type]
            num_workers=args.num_workers,
            seed=seed,
            backend=args.backend,
        )
        plant = mismatched_plant(
            args.task, seed, args.mass_scale, args.friction_scale, args.plant_overrides
        )
        plant.config = controller.task.config
        plant.reset()
        try:
            result = run_episode(controller, MujocoSystem(plant), args.duration, seed=seed)
        finally:
            controller.close()
        rows.append(result.metrics)
        plan_ms.append(float(np.median(result.update_ms)))
    means = {name: float(np.mean([row[name] for row in rows])) for name in HEADLINE[args.task]}
    return {**means, "plan_ms": float(np.mean(plan_ms))}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--task", default="leap_cube", choices=sorted(HEADLINE))
    parser.add_argument("--optimizers", nargs="+", default=["cem", "mppi"])
    parser.add_argument(
        "--randomizations", nargs="+", type=int, default=[1, 4], help="num_randomizations values"
    )
    parser.add_argument("--risks", nargs="+", default=["average", "cvar"], choices=RISK_MEASURES)
    parser.add_argument("--cvar-alpha", type=float, default=0.5)
    parser.add_argument(
        "--seeds",
        type=int,
        default=3,
        help="episodes, with seeds first-seed to first-seed + seeds - 1",
    )
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument(
        "--duration", type=float, default=60.0, help="seconds of sim time per episode"
    )
    parser.add_argument(
        "--num-workers", type=int, default=None, help="rollout threads (default: one per core)"
    )
    parser.add_argument("--backend", default="cpu", choices=["cpu", "warp"], help="rollout backend")
    parser.add_argument(
        "--num-rollouts",
        type=int,
        default=None,
        help="samples per iteration (default: the task's own)",
    )
    parser.add_argument(
        "--mass-scale", type=float, default=2.0, help="fr3_pick plant: object mass factor"
    )
    parser.add_argument(
        "--friction-scale", type=float, default=0.6, help="fr3_pick plant: object friction factor"
    )
    parser.add_argument(
        "--plant-overrides",
        nargs="+",
        default=list(LEAP_CUBE_PLANT),
        metavar="FIELD.ELEMENT=VALUE",
        help="leap_cube plant: its model fields (default: every contact's friction 0.9)",
    )
    args = parser.parse_args()
    for optimizer in args.optimizers:
        lookup_optimizer(optimizer)
    metrics = HEADLINE[args.task]
    plant = (
        " ".join(args.plant_overrides)
        if args.task == "leap_cube"
        else f"object mass x{args.mass_scale:g}, friction x{args.friction_scale:g}"
    )
    print(
        f"### {args.task} on a mismatched plant ({plant}), {args.seeds} seed(s) from "
        f"{args.first_seed} x {args.duration:g} s, "
        f"no latency, {args.backend} backend, num_rollouts {args.num_rollouts or 'of the task'}\n"
    )
    print(
        "| optimizer | num_randomizations | risk | " + " | ".join(metrics) + " | plan ms (median) |"
    )
    print("|---" * (len(metrics) + 4) + "|", flush=True)
    for optimizer in args.optimizers:
        for num_models in args.randomizations:
            for risk in ["average"] if num_models == 1 else args.risks:
                started = time.perf_counter()
                row = run_setting(args, optimizer, num_models, risk)
                label = (
                    "-"
                    if num_models == 1
                    else (f"cvar {args.cvar_alpha:g}" if risk == "cvar" else risk)
                )
                cells = " | ".join(f"{row[name]:.3g}" for name in metrics)
                print(
                    f"| {optimizer} | {num_models} | {label} | {cells} | {row['plan_ms']:.1f} |"
                    f"  <!-- {time.perf_counter() - started:.0f} s wall -->",
                    flush=True,
                )


if __name__ == "__main__":
    main()
