"""judo's MPPI against pytorch-mppi (UM-ARM-Lab's `pytorch_mppi`) on the same numpy/torch pendulum,
on the CPU.

Two figures for a researcher choosing between them: the time of one control update at the same N
samples x T steps, and closed-loop swing-up success (the share of the last 2 s of a 6 s episode
within 0.3 rad of upright) over seeds, each planner replanning every 20 ms step of the same plant.

PyTorch's wheel from the package index pulls several gigabytes of CUDA libraries, so pytorch-mppi
lives in a throwaway venv of its own, never in judo's extras or CI. This script runs its torch half
there:

    python -m venv /tmp/torch-bench-venv && /tmp/torch-bench-venv/bin/pip install torch pytorch-mppi
    PYTHONPATH=src python benchmarks/pytorch_mppi_comparison.py --torch-python /tmp/torch-bench-venv/bin/python

Both run on one CPU thread by default (judo's DynamicsRollout is one thread of
numpy; `--torch-threads` gives torch more). On a busy 2-core machine torch's default of one thread
per core made its N = 1024 update 20 times slower (116-150 ms against 6.3 ms on one thread). The
judo half runs in judo's own environment; the torch half (`--side torch`) imports only numpy, torch
and pytorch_mppi. Both plan the same dynamics: the pendulum of tests/core/test_dynamics.py (1
kg, 0.5 m, at most
2 Nm against 4.9 Nm of gravity, semi-implicit Euler at 20 ms), with the same running cost.
"""  # noqa: E501

import argparse
import json
import subprocess
import sys
import time

import numpy as np

DT = 0.02
GRAVITY_OVER_LENGTH, TORQUE_GAIN, DAMPING = 9.81 / 0.5, 2.0 / 0.25, 0.1
UPRIGHT = 0.3
"""Angle (rad) from upright within which the pole counts as up."""


def step(states: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """(N, 2) [angle (0 up), velocity] and (N, 1) torque fractions -> (N, 2) one step later."""
    angle, velocity = states[:, 0], states[:, 1]
    velocity = velocity + DT * (
        GRAVITY_OVER_LENGTH * np.sin(angle) + TORQUE_GAIN * controls[:, 0] - DAMPING * velocity
    )
    return np.stack([angle + DT * velocity, velocity], axis=1)


def wrapped(angle: np.ndarray) -> np.ndarray:
    return np.mod(angle + np.pi, 2 * np.pi) - np.pi


def start_state(seed: int) -> np.ndarray:
    return np.array([np.pi + np.random.default_rng(seed).uniform(-0.2, 0.2), 0.0])


def upright_fraction(angles: np.ndarray) -> float:
    return float(np.mean(np.abs(wrapped(angles[-int(2.0 / DT) :])) < UPRIGHT))


def judo_side(sizes: list[tuple[int, int]], seeds: int, repeats: int) -> dict:
    """Update ms per (N, T) and the swing-up per seed, with judo's MPPI (cubic spline, 4 knots)."""
    from dataclasses import dataclass

    import judo
    from judo.optimizers.mppi import MPPI, MPPIConfig

    @dataclass
    class Config(judo.TaskConfig):
        """No fields: the cost is fixed."""

    class Pendulum(judo.DynamicsTask[Config]):
        def __init__(self) -> None:
            super().__init__(nx=2, control_range=[[-1.0, 1.0]], dt=DT)

        def dynamics(self, states, controls, dt):
            return step(states, controls)

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return -(10.0 * np.abs(wrapped(states[..., 0])) + 0.05 * states[..., 1] ** 2).sum(-1)

    def controller(num_samples: int, num_steps: int, seed: int) -> judo.Controller:
        optimizer = MPPI(
            MPPIConfig(num_rollouts=num_samples, num_nodes=4, sigma=0.3, temperature=0.1), 1
        )
        optimizer.rng = np.random.default_rng(seed)
        config = judo.ControllerConfig(
            horizon=num_steps * DT, spline_order="cubic", control_freq=1 / DT
        )
        return judo.Controller(config, Pendulum(), optimizer)

    timings = {}
    for num_samples, num_steps in sizes:
        with controller(num_samples, num_steps, 0) as ctrl:
            ctrl.update_action(start_state(0), 0.0)  # layout built once
            times = []
            for i in range(repeats):
                start = time.perf_counter()
                ctrl.update_action(start_state(i), 0.0)
                times.append(time.perf_counter() - start)
        timings[f"{num_samples}x{num_steps}"] = 1e3 * float(np.median(times))
    success = []
    for seed in range(seeds):
        with controller(256, 75, seed) as ctrl:
            x, angles = start_state(seed), []
            for k in range(int(6.0 / DT)):
                ctrl.update_action(x, k * DT)
                x = step(x[None], ctrl.action(k * DT)[None])[0]
                angles.append(x[0])
        success.append(upright_fraction(np.array(angles)))
    return {"update_ms": timings, "upright": success}


def torch_side(sizes: list[tuple[int, int]], seeds: int, repeats: int, threads: int) -> dict:
    """The same with pytorch_mppi's MPPI (per-step noise, its own defaults), float64 on `threads`
    CPU threads."""
    import torch
    from pytorch_mppi import MPPI

    torch.set_default_dtype(torch.float64)
    torch.set_num_threads(threads)

    def dynamics(states, controls):
        angle, velocity = states[:, 0], states[:, 1]
        torque = controls[:, 0].clamp(-1.0, 1.0)
        velocity = velocity + DT * (
            GRAVITY_OVER_LENGTH * torch.sin(angle) + TORQUE_GAIN * torque - DAMPING * velocity
        )
        return torch.stack([angle + DT * velocity, velocity], dim=1)

    def cost(states, controls):
        angle = torch.remainder(states[:, 0] + torch.pi, 2 * torch.pi) - torch.pi
        return 10.0 * angle.abs() + 0.05 * states[:, 1] ** 2

    def controller(num_samples: int, num_steps: int) -> MPPI:
        return MPPI(
            dynamics, cost, 2, torch.tensor([[0.3]]), num_samples=num_samples, horizon=num_steps, device="cpu",  # noqa: E501
            lambda_=0.1, u_min=torch.tensor([-1.0]), u_max=torch.tensor([1.0]),
        )  # fmt: skip

    timings = {}
    for num_samples, num_steps in sizes:
        ctrl = controller(num_samples, num_steps)
        ctrl.command(torch.tensor(start_state(0)))
        times = []
        for i in range(repeats):
            start = time.perf_counter()
            ctrl.command(torch.tensor(start_state(i)))
            times.append(time.perf_counter() - start)
        timings[f"{num_samples}x{num_steps}"] = 1e3 * float(np.median(times))
    success = []
    for seed in range(seeds):
        torch.manual_seed(seed)
        ctrl = controller(256, 75)
        x, angles = start_state(seed), []
        for _ in range(int(6.0 / DT)):
            action = ctrl.command(torch.tensor(x)).numpy().reshape(1, 1)
            x = step(x[None], np.clip(action, -1.0, 1.0))[0]
            angles.append(x[0])
        success.append(upright_fraction(np.array(angles)))
    return {
        "update_ms": timings,
        "upright": success,
        "torch": torch.__version__,
        "threads": torch.get_num_threads(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--torch-python", help="the interpreter of the venv with torch and pytorch-mppi"
    )
    parser.add_argument("--side", choices=("both", "judo", "torch"), default="both")
    parser.add_argument("--samples", type=int, nargs="+", default=[32, 256, 1024])
    parser.add_argument("--steps", type=int, default=75)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument(
        "--torch-threads",
        type=int,
        default=1,
        help="torch's intra-op threads (judo's dynamics run on one)",
    )
    args = parser.parse_args()
    sizes = [(n, args.steps) for n in args.samples]
    if args.side == "judo":
        print(json.dumps(judo_side(sizes, args.seeds, args.repeats)))
        return
    if args.side == "torch":
        print(json.dumps(torch_side(sizes, args.seeds, args.repeats, args.torch_threads)))
        return
    if not args.torch_python:
        sys.exit(
            "--torch-python is needed: the interpreter of a throwaway venv with torch and "
            "pytorch-mppi"
        )
    common = [
        "--samples",
        *map(str, args.samples),
        "--steps",
        str(args.steps),
        "--seeds",
        str(args.seeds),
    ]
    common += ["--repeats", str(args.repeats), "--torch-threads", str(args.torch_threads)]
    results = {}
    for side, python in (("judo", sys.executable), ("torch", args.torch_python)):
        out = subprocess.run(
            [python, __file__, "--side", side, *common], check=True, capture_output=True, text=True
        )
        results[side] = json.loads(out.stdout.strip().splitlines()[-1])
    print(f"pendulum swing-up, CPU, float64; pytorch-mppi on torch {results['torch']['torch']} "
          f"({results['torch']['threads']} threads)\n")  # fmt: skip
    print("| N x T | judo mppi update ms | pytorch-mppi update ms |")
    print("|---|---|---|")
    for key in results["judo"]["update_ms"]:
        print(
            f"| {key} | {results['judo']['update_ms'][key]:.2f} | "
            f"{results['torch']['update_ms'][key]:.2f} |"
        )
    print(
        "\nupright fraction of the last 2 s of 6 s, N x T = 256 x 75, replanning every step, "
        f"{args.seeds} seeds:"
    )
    for side in ("judo", "torch"):
        values = np.array(results[side]["upright"])
        print(
            f"  {side}: mean {values.mean():.2f}, min {values.min():.2f} "
            f"({' '.join(f'{v:.2f}' for v in values)})"
        )


if __name__ == "__main__":
    main()
