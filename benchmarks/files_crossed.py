"""Which judo source files run code while the app makes steady-state control updates.

    PYTHONPATH=src python benchmarks/files_crossed.py [--task cartpole] [--optimizer mppi] [--seconds 1] [--callers]

Starts the app without a GUI, lets it warm up, then records for `--seconds` every judo file whose
functions are called, on every thread (the planner, the plant, the rollout workers), with a profile
hook. It prints each file with its calls per control update, and their count: the files a newcomer
would step through, bookkeeping included. docs/architecture.md lists the logical path of one update
beside it. With `--callers`, each file's functions follow it, each with its calls per update and the
function (file:name) that called it: why the update crosses that file.
"""  # noqa: E501

import argparse
import sys
import threading
import time
from collections import Counter

from judo.runtime.app import App


def where(frame) -> str:
    """ "file:function" of `frame`, the file named from judo/ on, or by its name alone outside
    judo."""
    if frame is None:
        return "?"
    name = frame.f_code.co_filename
    return f"{name.split('/judo/', 1)[1] if '/judo/' in name else name.rsplit('/', 1)[-1]}:{frame.f_code.co_name}"  # noqa: E501


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="cartpole")
    parser.add_argument("--optimizer", default="mppi")
    parser.add_argument(
        "--seconds", type=float, default=1.0, help="how long to record, after a 4 s warm-up"
    )
    parser.add_argument(
        "--callers", action="store_true", help="list each file's functions and who called them"
    )
    args = parser.parse_args()

    recording = threading.Event()
    calls: Counter[str] = Counter()
    # (file, function, the caller's file:function)
    callers: Counter[tuple[str, str, str]] = Counter()

    def hook(frame, event, arg) -> None:
        if event == "call" and recording.is_set():
            name = frame.f_code.co_filename
            if "/judo/" in name:
                calls[name.split("/judo/", 1)[1]] += 1
                if args.callers:
                    callers[
                        (name.split("/judo/", 1)[1], frame.f_code.co_name, where(frame.f_back))
                    ] += 1

    sys.setprofile(hook)
    threading.setprofile(hook)  # the app's threads start after this
    app = App(task=args.task, optimizer=args.optimizer, gui=False)
    app.start()
    try:
        time.sleep(4.0)
        before = app.stats.num_plans()
        recording.set()
        time.sleep(args.seconds)
        recording.clear()
        updates = app.stats.num_plans() - before
    finally:
        sys.setprofile(None)
        app.stop()
    print(f"{args.task} with {args.optimizer}: {updates} control updates in {args.seconds:g} s")
    print(f"{'calls/update':>12}  file")
    for name, count in sorted(calls.items()):
        print(f"{count / max(updates, 1):12.1f}  {name}")
        for (_, function, caller), times in sorted(
            item for item in callers.items() if item[0][0] == name
        ):
            print(f"{times / max(updates, 1):16.1f}  {function} <- {caller}")
    print(f"{len(calls)} files run code during steady-state updates")


if __name__ == "__main__":
    main()
