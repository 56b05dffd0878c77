"""The best settings of a tune as a `--config` TOML file, so `python -m judo --config best.toml`
uses them."""

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from judo.core.errors import JudoError

SECTIONS = {
    "controller": "controller_config_overrides.{task}.{optimizer}",
    "optimizer": "optimizer_config_overrides.{task}.{optimizer}",
    "task": "task_config_overrides.{task}",
}
"""The --config table each kind of parameter goes in: a tune is of one optimizer, so its controller
settings apply with that optimizer alone (after the task-wide section), and never change the task's
other optimizers."""


def toml_value(value: Any) -> str:
    """`value` (bool, int, float or str) as a TOML literal."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise JudoError(f"cannot write the non-finite value {value} to a config file")
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    raise JudoError(
        f"cannot write {value!r} ({type(value).__name__}) to a config file; expected bool, "
        "int, float or str"
    )


def best_toml(task: str, optimizer: str, values: dict[str, Any], header: Sequence[str] = ()) -> str:
    """The text of a --config file setting `values` ({`kind.field`: value}) for the pair.

    `header` lines become comments at the top (the command that found the values, the score). The
    file also names the pair as the initial `task` and `optimizer`, so the app opens on them.
    """
    lines = [f"# {line}" if line else "#" for line in header]
    lines += ["", f"task = {toml_value(task)}", f"optimizer = {toml_value(optimizer)}"]
    for kind, template in SECTIONS.items():
        entries = {
            name.split(".", 1)[1]: value
            for name, value in values.items()
            if name.split(".", 1)[0] == kind
        }
        if not entries:
            continue
        lines += ["", f"[{template.format(task=task, optimizer=optimizer)}]"]
        lines += [f"{field} = {toml_value(value)}" for field, value in sorted(entries.items())]
    return "\n".join(lines).lstrip("\n") + "\n"


def write_best_toml(
    path: Path, task: str, optimizer: str, values: dict[str, Any], header: Sequence[str] = ()
) -> None:
    """Write `best_toml(...)` to `path`, creating its folder; JudoError if that fails."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(best_toml(task, optimizer, values, header))
    except OSError as err:
        raise JudoError(f"could not write {path}: {err}") from err
