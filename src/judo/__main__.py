"""`python -m judo` (and the `judo` script): the app, or the `benchmark`, `evaluate`, `tune`, `leaderboard`,
`collect`, `replay`, `distill`, `gait-search`, `sysid` and `excite` commands.

python -m judo --task cartpole --optimizer mppi     # the app; --help lists its options
python -m judo benchmark ...                        # judo.evaluation.benchmark
python -m judo evaluate ...                         # judo.evaluation.evaluate
python -m judo tune ...                             # judo.tuning.cli (needs the `tune` extra)
python -m judo leaderboard --tasks ...              # judo.tuning.leaderboard: which optimizer wins where
python -m judo collect ...                          # judo.collection.cli (needs the `collect` extra)
python -m judo replay FILE.h5                       # judo.collection.replay: a collect file in the GUI
python -m judo distill DATA.h5 --out POLICY.onnx    # judo.learning.cli: a policy from collect's files
python -m judo gait-search --out POLICY.onnx        # judo.learning.gait_cli: the quadruped's locomotion policy
python -m judo plant --task cartpole                # judo.ros2.plant: the simulator as a ROS 2 robot process
python -m judo sysid LOG.h5 --task T --params ... --out FITTED.toml   # judo.collection.sysid_cli: fit the model
python -m judo excite --task T --out LOG.h5         # judo.collection.excite: a log worth fitting

Every command ends the same way on what it cannot handle: an exception raised by the user's own code (a
task, optimizer or config class, a reward) is told in one line naming the class, file and line, with exit
status 1 (`--debug` anywhere on the line shows the whole traceback instead); Ctrl-C exits 130. A warning is
printed as one line, "warning: MESSAGE", without Python's file path and source line.
"""

import sys
import warnings
from collections.abc import Sequence

PROG = "python -m judo"


def one_line_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int, line=None) -> str:
    """A warning as the commands print it: one clean line, without the file path and source line Python adds."""
    text = str(message).strip().splitlines()
    return f"warning: {text[0] if text else category.__name__}\n"


def main(argv: Sequence[str] | None = None) -> int | None:
    """Dispatch `argv` (default: sys.argv[1:]) to a command and return its exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    if not debug:  # --debug keeps Python's own form, with the file and line
        warnings.formatwarning = one_line_warning
    argv = [arg for arg in argv if arg != "--debug"]
    commands = (
        "benchmark",
        "evaluate",
        "tune",
        "leaderboard",
        "collect",
        "replay",
        "distill",
        "gait-search",
        "plant",
        "sysid",
        "excite",
    )
    prog = f"{PROG} {argv[0]}" if argv and argv[0] in commands else PROG
    try:
        return dispatch(argv)
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except Exception as err:  # the user's code failed (judo's own errors are told by each command)
        if debug:
            raise
        from judo.core.commandline.boundary import user_error_line

        print(f"{prog}: {user_error_line(err)} (--debug shows the traceback)", file=sys.stderr)
        return 1


def dispatch(argv: list[str]) -> int | None:
    """Run the command `argv` names and return its exit status."""
    if argv and argv[0] == "benchmark":
        from judo.evaluation.benchmark import main as benchmark_main

        return benchmark_main(argv[1:])
    if argv and argv[0] == "evaluate":
        from judo.evaluation.evaluate import main as evaluate_main

        return evaluate_main(argv[1:])
    if argv and argv[0] == "tune":
        from judo.tuning.cli import main as tune_main

        return tune_main(argv[1:])
    if argv and argv[0] == "leaderboard":
        from judo.tuning.leaderboard import main as leaderboard_main

        return leaderboard_main(argv[1:])
    if argv and argv[0] == "collect":
        from judo.collection.cli import main as collect_main

        return collect_main(argv[1:])
    if argv and argv[0] == "replay":
        from judo.collection.replay import main as replay_main

        return replay_main(argv[1:])
    if argv and argv[0] == "distill":
        from judo.learning.cli import main as distill_main

        return distill_main(argv[1:])
    if argv and argv[0] == "plant":
        from judo.ros2.plant import main as plant_main

        return plant_main(argv[1:])
    if argv and argv[0] == "sysid":
        from judo.collection.sysid_cli import main as sysid_main

        return sysid_main(argv[1:])
    if argv and argv[0] == "excite":
        from judo.collection.excite import main as excite_main

        return excite_main(argv[1:])
    if argv and argv[0] == "gait-search":
        from judo.learning.gait_cli import main as gait_search_main

        return gait_search_main(argv[1:])
    from judo.runtime.cli import main as app_main

    return app_main(argv)


if __name__ == "__main__":
    sys.exit(main())
