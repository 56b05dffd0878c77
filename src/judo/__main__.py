"""`python -m judo` (and the `judo` script): the app, or one of the commands in COMMANDS.

python -m judo --task cartpole --optimizer mppi     # the app (judo.runtime.launch); --help lists its options
python -m judo benchmark ...                        # judo.evaluation.benchmark
python -m judo evaluate ...                         # judo.evaluation.evaluate
python -m judo tune ...                             # judo.tuning.tune (needs the `tune` extra)
python -m judo leaderboard --tasks ...              # judo.tuning.leaderboard: which optimizer wins where
python -m judo collect ...                          # judo.collection.collect (needs the `collect` extra)
python -m judo replay FILE.h5                       # judo.runtime.gui.replay: a collect file in the GUI
python -m judo distill DATA.h5 --out POLICY.onnx    # judo.learning.distill: a policy from collect's files
python -m judo gait-search --out POLICY.onnx        # judo.learning.gait_search: the quadruped's locomotion policy
python -m judo plant --task cartpole                # judo.ros2.plant (judo.unitree.robot too): the simulator as a robot
python -m judo sysid LOG.h5 --task T --params ... --out FITTED.toml   # judo.sysid.sysid: fit the model
python -m judo excite --task T --out LOG.h5         # judo.sysid.excite: a log worth fitting

Every command ends the same way on what it cannot handle: an exception raised by the user's own code
(a task, optimizer or config class, a reward) is told in one line naming the class, file and line,
with exit status 1 (`--debug` anywhere on the line shows the whole traceback instead); Ctrl-C exits
130. A warning is printed as one line, "warning: MESSAGE", without Python's file path and source
line.
"""  # noqa: E501

import importlib
import sys
import warnings
from collections.abc import Sequence

PROG = "python -m judo"

COMMANDS = {
    "benchmark": "judo.evaluation.benchmark:main",
    "evaluate": "judo.evaluation.evaluate:main",
    "tune": "judo.tuning.tune:main",
    "leaderboard": "judo.tuning.leaderboard:main",
    "collect": "judo.collection.collect:main",
    "replay": "judo.runtime.gui.replay:main",
    "distill": "judo.learning.distill:main",
    "gait-search": "judo.learning.gait_search:main",
    "plant": "judo.unitree.robot:main",
    "sysid": "judo.sysid.sysid:main",
    "excite": "judo.sysid.excite:main",
}
"""Each command's name -> "module:function" of its entry point, which takes the arguments after the
name and returns the exit status. The module is imported only when its command runs."""

APP = "judo.runtime.launch:main"
"""The entry point of the app, run when the first argument names no command."""


def one_line_warning(
    message: Warning | str, category: type[Warning], filename: str, lineno: int, line=None
) -> str:
    """A warning as the commands print it: one clean line, without the file path and source line
    Python adds."""
    text = str(message).strip().splitlines()
    return f"warning: {text[0] if text else category.__name__}\n"


def main(argv: Sequence[str] | None = None) -> int | None:
    """Dispatch `argv` (default: sys.argv[1:]) to a command and return its exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    if not debug:  # --debug keeps Python's own form, with the file and line
        warnings.formatwarning = one_line_warning
    argv = [arg for arg in argv if arg != "--debug"]
    prog = f"{PROG} {argv[0]}" if argv and argv[0] in COMMANDS else PROG
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
    """Run the command `argv` names (the app when it names none) and return its exit status."""
    command = argv[0] if argv and argv[0] in COMMANDS else None
    module, _, function = (APP if command is None else COMMANDS[command]).partition(":")
    entry = getattr(importlib.import_module(module), function)
    return entry(argv if command is None else argv[1:])


if __name__ == "__main__":
    sys.exit(main())
