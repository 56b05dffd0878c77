"""`python -m judo distill`: train a policy from collect's datasets and write it as ONNX
(docs/learning.md).

python -m judo distill cartpole.h5 --out cartpole_policy.onnx
python -m judo distill cartpole.h5 --out cartpole_policy.onnx --rounds 3      # the MPC as teacher (DAgger)
"""  # noqa: E501

import shlex
import sys

from judo.cli_shared import fail, output_console, parse_args, progress_console
from judo.core.errors import JudoError
from judo.learning.args import DistillArgs

DESCRIPTION = (
    "Train a policy on the episodes of python -m judo collect (one task; several files are "
    "read together) and "
    "write it as an ONNX file that needs nothing else to run: python -m judo evaluate --task "
    "T --policy OUT.onnx, "
    "or as proposals with --proposal-policy. --kind action learns the next action from each "
    "state; --kind chunk "
    "learns each control update's plan knots (what the MPC plans; the kind that serves as a "
    "proposal). The split "
    "into training and validation is by episode; training stops early on the validation "
    "loss, and the loss curves "
    "are saved beside the ONNX file as a PNG. With --rounds R the MPC is then the teacher "
    "(DAgger): each round "
    "collects --episodes-per-round new episodes on Ray in which the policy drives and the "
    "MPC labels the states it "
    "visits, retrains on everything, and prints the policy alone and the MPC with its "
    "proposals on fresh seeds. "
    "Needs the `learn` extra: pip install -e '.[learn]'."
)


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo distill` on `argv` (sys.argv[1:] when None); exits with status 2 on bad
    arguments."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(DistillArgs, argv, "python -m judo distill", DESCRIPTION)
    command = "python -m judo distill " + shlex.join(argv)
    try:
        args.validate()
        from judo.core.errors import import_extra

        for module in ("jax", "optax", "onnx", "h5py"):
            import_extra(module, "python -m judo distill", "learn")
        from judo.learning.rounds import distill

        distill(args, command, output_console(), progress_console())
    except JudoError as err:
        fail(str(err))
    return 0
