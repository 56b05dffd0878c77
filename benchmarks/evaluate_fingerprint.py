"""The evaluate fingerprint: sim-time metrics that a refactor must leave unchanged, bit for bit.

Runs `python -m judo evaluate` for every task x optimizer x fixed latency (2 seeds each by default:
cartpole, pendulum and particle; ps, cem and mppi; 0 and 20 ms) and writes each run's per-seed
metrics, update counts, failed updates and divergences to one JSON file. Wall times are left out:
they vary from run to run.

    PYTHONPATH=src python benchmarks/evaluate_fingerprint.py --out before.json      # on the commit before
    PYTHONPATH=src python benchmarks/evaluate_fingerprint.py --compare before.json  # after: prints what differs

Exits 1 when a run differs from the file compared with.
"""  # noqa: E501

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path


def fingerprint(args: argparse.Namespace) -> dict[str, list]:
    """{"task/optimizer/latency ms": [[seed, metrics, num_updates, failed_updates, divergences],
    ...]}."""
    runs = {}
    with tempfile.TemporaryDirectory() as folder:
        for task in args.tasks:
            for optimizer in args.optimizers:
                for latency in args.latency_ms:
                    out = Path(folder) / "run.json"
                    command = [
                        sys.executable,
                        "-m",
                        "judo",
                        "evaluate",
                        "--task",
                        task,
                        "--optimizer",
                        optimizer,
                    ]
                    command += ["--seeds", str(args.seeds), "--duration", str(args.duration)]
                    command += [
                        "--latency-ms",
                        str(latency),
                        "--num-workers",
                        "2",
                        "--json",
                        str(out),
                    ]
                    done = subprocess.run(command, capture_output=True, text=True, env=os.environ)
                    if done.returncode != 0:
                        sys.exit(
                            f"evaluate_fingerprint: {' '.join(command[1:])} "
                            f"failed:\n{done.stderr[-2000:]}"
                        )
                    episodes = json.loads(out.read_text())["episodes"]
                    key = f"{task}/{optimizer}/{latency:g} ms"
                    runs[key] = [
                        [
                            e["seed"],
                            e["metrics"],
                            e["num_updates"],
                            e["failed_updates"],
                            e["divergences"],
                        ]
                        for e in episodes
                    ]
                    print(f"{key}: {len(episodes)} episodes", file=sys.stderr)
    return runs


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--tasks", nargs="+", default=["cartpole", "pendulum", "particle"])
    parser.add_argument("--optimizers", nargs="+", default=["ps", "cem", "mppi"])
    parser.add_argument("--latency-ms", nargs="+", type=float, default=[0.0, 20.0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument(
        "--duration", type=float, default=4.0, help="seconds of sim time per episode"
    )
    parser.add_argument("--out", type=Path, help="write the fingerprint here")
    parser.add_argument(
        "--compare", type=Path, help="a fingerprint written before: print the runs that differ"
    )
    args = parser.parse_args()
    runs = fingerprint(args)
    if args.out is not None:
        args.out.write_text(json.dumps(runs, indent=1))
        print(f"wrote {len(runs)} runs to {args.out}")
    if args.compare is None:
        return 0
    before = json.loads(args.compare.read_text())
    differ = sorted(key for key in runs if runs[key] != before.get(key))
    for key in differ:
        print(f"differs: {key}\n  before: {before.get(key)}\n  now:    {runs[key]}")
    print(f"{len(runs)} runs compared with {args.compare}: {len(differ)} differ")
    return 1 if differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
