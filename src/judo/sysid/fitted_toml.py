"""The --config file a sysid fit writes (judo.sysid.sysid): the run's --config carried over with
the fitted parameters in its [model_overrides.TASK], the entries fitted in its [sysid.TASK], and
comments on a delay the planning model cannot hold.
"""

import json
import math
from typing import Any


def delay_note(result: Any, model: Any) -> list[str]:
    """Comment lines for a fitted delay that the planning model cannot hold (no actuator history),
    else []."""
    from judo.sysid.parameters import delay_fits_model

    delay = result.delay
    if delay is None or delay_fits_model(model, delay):
        return []
    samples = int(math.ceil(delay / float(model.opt.timestep) - 1e-9)) + 1
    return [
        f"fitted actuation delay: {delay:.6g} s. The planning model keeps no action history, "
        "so MuJoCo would ignore",
        f'an actuator_delay here: add delay="{delay:.6g}" nsample="{samples}" '
        'interp="linear" to its actuators in the',
        f"MJCF, or plan ahead of it with --latency-ms {delay * 1000:.3g} "
        "--controller.latency-compensation.",
    ]


def command_delay_note(result: Any) -> list[str]:
    """A comment line for a command delay found in the log, else []."""
    if result.command_delay == 0:
        return []
    seconds = result.command_delay * result.timestep
    return [
        f"commands reached the plant {seconds:.3g} s ({result.command_delay} model steps) "
        "late in this log: plan "
        f"ahead of it with --latency-ms {seconds * 1000:.3g} --controller.latency-compensation"
    ]


def fitted_toml(
    task: str,
    overrides: dict[str, dict[str, Any]],
    header: list[str],
    config: dict[str, Any],
    notes: list[str] | tuple[str, ...] = (),
) -> str:
    """The --config file of the fit: `header` as comments, then `config` (the --config file's
    table), whose [model_overrides.TASK] gets the fitted `overrides` (replacing the entries they
    fit, keeping the others), with `notes` as comments at its end, and whose [sysid.TASK] names the
    entries sysid fitted (these and those the config's own [sysid.TASK] named), so that judo
    announces a fitted model."""
    from judo.core.configuration.model_overrides import toml_value

    model_overrides = {
        name: dict(value) for name, value in config.get("model_overrides", {}).items()
    }
    merged: dict[str, dict[str, Any]] = {
        f: dict(v) for f, v in model_overrides.pop(task, {}).items()
    }
    for field_name, values in overrides.items():
        for element, value in values.items():
            merged.setdefault(field_name, {})[element] = toml_value(value)
    rest = {key: value for key, value in config.items() if key != "model_overrides"}
    sysid_tables = {name: dict(value) for name, value in rest.pop("sysid", {}).items()}
    named = [name.partition(".") for name in sysid_tables.pop(task, {}).get("fitted", [])]
    # still set: fitted by an earlier sysid
    before = [f"{f}.{e}" for f, _, e in named if e in merged.get(f, {})]
    fitted = before + [
        f"{f}.{e}" for f, values in overrides.items() for e in values if f"{f}.{e}" not in before
    ]
    if fitted:
        sysid_tables[task] = {"fitted": fitted}
    if sysid_tables:
        rest["sysid"] = sysid_tables
    if model_overrides:
        rest["model_overrides"] = model_overrides
    lines = (
        [f"# {line}" for line in header] + _toml_lines([], rest) + ["", f"[model_overrides.{task}]"]
    )
    for field_name, values in merged.items():
        for element, value in values.items():
            lines.append(f"{field_name}.{_key(element)} = {_toml_literal(value)}")
    if not overrides:
        lines.append("# no parameter was determined by the data; see the report")
    lines += [f"# {line}" for line in notes]
    return "\n".join(lines) + "\n"


def _toml_lines(path: list[str], table: dict[str, Any]) -> list[str]:
    """TOML lines of `table` under the header `path`: its plain keys, then each sub-table as its own
    section."""
    plain = {key: value for key, value in table.items() if not isinstance(value, dict)}
    has_tables = any(isinstance(value, dict) for value in table.values())
    lines = (
        ["", "[" + ".".join(_key(part) for part in path) + "]"]
        if path and (plain or not has_tables)
        else []
    )
    lines += [f"{_key(key)} = {_toml_literal(value)}" for key, value in plain.items()]
    for key, value in table.items():
        if isinstance(value, dict):
            lines += _toml_lines([*path, key], value)
    return lines


def _toml_literal(value: Any) -> str:
    """A TOML value: a string (JSON's escapes are TOML's), a boolean, a number or a list of them."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_literal(item) for item in value) + "]"
    return json.dumps(str(value))


def _key(name: str) -> str:
    """An element name as a TOML key: bare where it can be, else quoted."""
    return (
        name
        if name.replace("_", "").replace("-", "").isalnum()
        else '"' + name.replace('"', '\\"') + '"'
    )
