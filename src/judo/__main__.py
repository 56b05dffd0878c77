"""`python -m judo` (and the `judo` script): the app, or the `benchmark`, `evaluate`, `tune`, `collect`
and `replay` commands.

python -m judo --task cartpole --optimizer mppi     # the app; --help lists its options
python -m judo benchmark ...                        # judo.evaluation.benchmark
python -m judo evaluate ...                         # judo.evaluation.evaluate
python -m judo tune ...                             # judo.tuning.cli (needs the `tune` extra)
python -m judo collect ...                          # judo.collection.cli (needs the `collect` extra)
python -m judo replay FILE.h5                       # judo.collection.replay: a collect file in the GUI
"""

import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int | None:
    """Dispatch `argv` (default: sys.argv[1:]) to a command and return its exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "benchmark":
        from judo.evaluation.benchmark import main as benchmark_main

        return benchmark_main(argv[1:])
    if argv and argv[0] == "evaluate":
        from judo.evaluation.evaluate import main as evaluate_main

        return evaluate_main(argv[1:])
    if argv and argv[0] == "tune":
        from judo.tuning.cli import main as tune_main

        return tune_main(argv[1:])
    if argv and argv[0] == "collect":
        from judo.collection.cli import main as collect_main

        return collect_main(argv[1:])
    if argv and argv[0] == "replay":
        from judo.collection.replay import main as replay_main

        return replay_main(argv[1:])
    from judo.runtime.cli import main as app_main

    return app_main(argv)


if __name__ == "__main__":
    sys.exit(main())
