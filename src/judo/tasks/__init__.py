"""Built-in tasks, one per file with its config; models/ holds the MJCF; judo.builtin registers them
by name.

Each task's defaults (the per-task overrides that solve it out of the box, each with a comment on
the sweep that chose it) are data: models/<task>.toml, in the `--config` file format, read by the
same loader when judo.builtin registers the task.
"""
