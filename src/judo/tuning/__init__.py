"""`python -m judo tune`: search a task x optimizer's settings with Optuna, running trials as Ray
tasks.

space.py      the search space, from the config dataclasses and their @slider ranges; --params / --fix
objective.py  the metric being optimised and its direction
trial.py      one trial: seeded closed-loop episodes (evaluate's runner) with the trial's settings
best_file.py  the best settings as a `--config` TOML file
study.py      the Optuna study: storage, sampler, ask/tell while each trial's episodes run as Ray tasks
              (judo.ray_cluster starts or joins Ray)
report.py     the outputs: table, trials.csv, plots
tune.py       the command line
tune_args.py  its arguments (TuneArgs) and their checks

Nothing here imports optuna or ray at import time: study.py imports them when called, and
only the command imports it (it needs the `tune` extra).
"""  # noqa: E501
