"""The controller's overhead with randomized models: the control update against the raw rollout of
the same N x R x T steps, timed alternately on the same pool, for R = 1 and larger R; and the cost
of one redraw.

Prints the median and the minimum of each ratio (the minimum is the steadier figure on a loaded
machine).

    PYTHONPATH=src python benchmarks/randomized_overhead.py --task leap_cube --optimizer cem --randomizations 1 4
"""  # noqa: E501

import argparse
import time

import numpy as np

from judo.core.rollouts.randomize import randomized_models
from judo.evaluation.timing import benchmark_controller, time_control_update


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--task", default="leap_cube")
    parser.add_argument("--optimizer", default="cem")
    parser.add_argument("--randomizations", nargs="+", type=int, default=[1, 4])
    parser.add_argument("--samples", type=int, default=50)
    parser.add_argument("--warmup", type=int, default=5)
    parser.add_argument(
        "--num-workers", type=int, default=None, help="rollout threads (default: one per core)"
    )
    parser.add_argument(
        "--cpu-time",
        action="store_true",
        help="time the calling thread's CPU time instead of wall time (needs --num-workers 1; "
        "steadier on a busy machine)",
    )
    args = parser.parse_args()
    if args.cpu_time and args.num_workers != 1:
        parser.error(
            "--cpu-time needs --num-workers 1, so that every rollout runs on the timed thread"
        )
    clock = time.thread_time if args.cpu_time else time.perf_counter
    what = "thread CPU time" if args.cpu_time else "wall time"
    print(
        f"### {args.task} x {args.optimizer}: update / raw rollout of N x R x T (times "
        "max_opt_iters), "
        f"{args.samples} samples, {what}\n"
    )
    print(
        "| R | N x R x T | update ms (median) | raw ms (median) | ratio (median) | ratio (min / "
        "min) | redraw ms |"
    )
    print("|---|---|---|---|---|---|---|", flush=True)
    for num_models in args.randomizations:
        controller = benchmark_controller(
            args.task,
            args.optimizer,
            num_workers=args.num_workers,
            controller_updates={"num_randomizations": num_models},
        )
        try:
            update_ms, raw_ms = time_control_update(
                controller, args.samples, args.warmup, clock=clock
            )
            # the floor: one raw batch per optimizer iteration
            raw_ms = raw_ms * controller.config.max_opt_iters
            started = time.perf_counter()
            randomized_models(controller.task, num_models, np.random.default_rng(0))
            redraw_ms = 1e3 * (time.perf_counter() - started)
        finally:
            controller.close()
        shape = f"{controller.optimizer.num_rollouts} x {num_models} x {controller.num_steps}"
        print(
            f"| {num_models} | {shape} | {np.median(update_ms):.1f} | {np.median(raw_ms):.1f} | "
            f"{np.median(update_ms) / np.median(raw_ms):.3f} | "
            f"{update_ms.min() / raw_ms.min():.3f} | {redraw_ms:.2f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
