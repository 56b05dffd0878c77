"""The policy as a proposal: closed-loop quality at N and N/8 rollouts, with and
without `policy_samples`.

On cartpole (swing-up from hanging, then balance, centred), the proposal policy is good but not
perfect: the LQR law of the planning model linearised upright, u = -K (x - x*), on the pole angle
rebuilt (wrapped) from the task's observation [cart x, cos, sin, velocities], saturated by the
actuator, with its cart target x* moved off centre by
--offset (the task wants the cart at 0). It balances a pole near the top, but cannot swing one up
and balances the cart in the wrong place. It is an action policy (H = 1), so each update rolls it
out in closed loop on the planning model and fits it to the knots (judo.core.policies.proposals).
Each row runs the task's default controller with num_rollouts N (or N/8) and policy_samples 0 or K,
over fresh seeds (--first-seed; the task's defaults were tuned on seeds 0-4), and shows the task's
metrics (mean and 95% CI over seeds) in sim time, and the median update time in wall time
(which the machine's load moves; the metrics do not depend on it).

    PYTHONPATH=src python benchmarks/proposals.py --optimizers ps cem mppi --seeds 5 --duration 10
"""

from dataclasses import dataclass, field

import mujoco
import numpy as np
import tyro
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
)
from rich.table import Table

import judo
from judo.core.configuration.config import with_updates
from judo.core.configuration.registry import lookup_optimizer, lookup_task, make_config
from judo.core.lqr import lqr_cost_to_go
from judo.core.norms import wrap_angle
from judo.evaluation.episode import run_episode
from judo.evaluation.stats import summarize
from judo.loop.system import MujocoSystem

TASK = "cartpole"
METRICS = ("balanced_fraction", "swung_up", "mean_reward")


@dataclass
class Args:
    """Which optimizers, rollout counts, proposal counts, seeds and episode length."""

    optimizers: list[str] = field(default_factory=lambda: ["ps", "cem", "mppi"])
    """Optimizers, by registered name."""
    num_rollouts: int = 64
    """N, the task's default; each optimizer also runs with N // 8."""
    policy_samples: int = 2
    """K, the candidates from the policy when proposals are on (at most N // 8 - 1)."""
    offset: float = 0.2
    """Where the LQR law holds the cart, in m off centre: what makes it good but not perfect."""
    seeds: int = 5
    """Episodes per row, with seeds first_seed to first_seed + seeds - 1."""
    first_seed: int = 100
    """The first seed: fresh ones by default, not those the defaults were tuned on."""
    duration: float = 10.0
    """Seconds of sim time per episode."""
    num_workers: int | None = None
    """Rollout threads (default: one per core)."""


class CartpoleLQR(judo.Policy):
    """u = clip(-K (x - x*)) on x = [cart x, wrapped pole angle, velocities]: the LQR law of `model`
    upright, on cartpole's observation [cart x, cos angle, sin angle, cart velocity, angular
    velocity], whose angle is arctan2(sin, cos)."""

    def __init__(self, model: mujoco.MjModel, offset: float) -> None:
        self.observation_size, self.action_size, self.horizon = 5, 1, 1
        self.metadata = {"task": TASK, "name": f"lqr (cart held at {offset:g} m)"}
        weights, control_weight = np.array([1.0, 10.0, 0.1, 0.1]), 0.1
        cost_to_go = lqr_cost_to_go(model, weights, control_weight)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        a, b = np.zeros((4, 4)), np.zeros((4, model.nu))
        mujoco.mjd_transitionFD(model, data, 1e-6, True, a, b, None, None)
        self.gain = np.linalg.solve(
            control_weight * np.eye(model.nu) + b.T @ cost_to_go @ b, b.T @ cost_to_go @ a
        )
        self.target = np.array([offset, 0.0, 0.0, 0.0])

    def act(self, observations: np.ndarray) -> np.ndarray:
        angle = np.arctan2(observations[:, 2], observations[:, 1])
        states = np.column_stack(
            [observations[:, 0], angle, observations[:, 3], observations[:, 4]]
        )
        deviations = states - self.target
        deviations[:, 1] = wrap_angle(deviations[:, 1])
        return np.minimum(np.maximum(-deviations @ self.gain.T, -1.0), 1.0)[:, None, :]


def run_row(
    args: Args,
    policy: judo.Policy,
    optimizer: str,
    num_rollouts: int,
    samples: int,
    progress: Progress,
    bar: TaskID,
) -> dict:
    """Each metric's summary over the seeds' episodes, and every update's wall time in ms, of one
    row."""
    controller_config = with_updates(
        make_config(judo.ControllerConfig, TASK, optimizer), {"policy_samples": samples}
    )
    optimizer_config = with_updates(
        make_config(lookup_optimizer(optimizer)[1], TASK), {"num_rollouts": num_rollouts}
    )
    if hasattr(optimizer_config, "num_elites"):
        optimizer_config.num_elites = min(optimizer_config.num_elites, num_rollouts)  # type: ignore[attr-defined]
    metrics: dict[str, list[float]] = {name: [] for name in METRICS}
    update_ms = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        with judo.make_controller(
            TASK,
            optimizer,
            controller_config=controller_config,  # type: ignore[arg-type]
            optimizer_config=optimizer_config,
            num_workers=args.num_workers,
            seed=seed,
            proposal_policy=policy if samples else None,
        ) as controller:
            result = run_episode(
                controller, MujocoSystem.from_task(controller.task, seed), args.duration, seed=seed
            )
        for name in METRICS:
            metrics[name].append(result.metrics[name])
        update_ms.extend(result.update_ms)
        progress.advance(bar)
    return {
        "summaries": {name: summarize(np.array(values)) for name, values in metrics.items()},
        "ms": update_ms,
    }


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    for optimizer in args.optimizers:
        lookup_optimizer(optimizer)
    small = args.num_rollouts // 8
    if not 1 <= args.policy_samples < small:
        raise SystemExit(
            f"error: --policy-samples must be from 1 to N // 8 - 1 = {small - 1}, got "
            f"{args.policy_samples}"
        )
    policy = CartpoleLQR(lookup_task(TASK)[0]().model, args.offset)
    rows = [
        (opt, n, k)
        for opt in args.optimizers
        for n in (args.num_rollouts, small)
        for k in (0, args.policy_samples)
    ]
    table = Table(
        title=f"{TASK}: proposals from an LQR law holding the cart at {args.offset:g} m, seeds "
        f"{args.first_seed}-"
        f"{args.first_seed + args.seeds - 1} x {args.duration:g} s (sim time), mean ± 95% CI"
    )
    for column in ("optimizer", "num_rollouts", "policy_samples", *METRICS, "update ms (median)"):
        table.add_column(column, justify="right")
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    with Progress(*columns, console=Console(stderr=True), transient=True) as progress:
        bar = progress.add_task("episodes", total=len(rows) * args.seeds)
        for optimizer, num_rollouts, samples in rows:
            progress.update(bar, description=f"{optimizer} N={num_rollouts} K={samples}")
            row = run_row(args, policy, optimizer, num_rollouts, samples, progress, bar)
            cells = [f"{s.mean:.3g} ± {s.ci95:.2g}" for s in row["summaries"].values()]
            table.add_row(
                optimizer, str(num_rollouts), str(samples), *cells, f"{np.median(row['ms']):.1f}"
            )
    Console(width=160).print(table)


if __name__ == "__main__":
    main()
