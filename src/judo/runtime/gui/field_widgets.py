"""How one config field shows in a widget of a `ConfigPanel`: its label and hover hint, a number
as a box shows and reads it, a slider over a range (a default one around the value for a field
without `@slider`) with a round step, and the refusal of a page's value beyond a slider's range.
"""

import math
from typing import Any

import viser

from judo.core.configuration.fields import SliderRange
from judo.core.errors import ConfigError


def field_label(name: str) -> str:
    """The label a field's widget shows: its name in words ("max num traces"), which a narrow panel
    wraps between words, never inside one as it would wrap "max_num_traces"."""
    return name.replace("_", " ")


def field_hint(name: str, doc: str | None) -> str:
    """The hover hint of a field's widget: its exact name (as in code, configs and the CLI), then
    its doc."""
    return f"{name}: {doc}" if doc else name


def encode_log(value: float) -> list[Any]:
    """[value as text] for a log field's box."""
    return [format_number(value)]


def format_number(value: float) -> str:
    """`value` as a box shows it: to 12 significant digits ("20", "0.3", "1e-05"), or every digit
    needed to read it back exactly."""
    text = f"{float(value):.12g}"
    return text if float(text) == float(value) else repr(float(value))


def parse_number(name: str, text: Any) -> float:
    """The number typed as `text` into field `name`'s box. Raises ConfigError if it is not one."""
    try:
        return float(text)
    except (TypeError, ValueError):
        raise ConfigError(
            f"{name} must be a number, like 0.25 or 1e-3; got {str(text)!r}"
        ) from None


def add_slider(
    gui: viser.GuiApi, label: str, value: Any, rng: SliderRange | None, integer: bool, doc: str
):
    """A slider over `rng` (or a default range around `value`), widened to include `value`."""
    rng = rng or default_range(value, integer)
    low, high = min(rng.min, value), max(rng.max, value)
    step = rng.step or nice_step(high - low)
    if integer:
        low, high, step, value = math.floor(low), math.ceil(high), max(1, round(step)), int(value)
    else:
        low, high, step, value = float(low), float(high), float(step), float(value)
    return gui.add_slider(label, min=low, max=high, step=step, initial_value=value, hint=doc)


def default_range(value: float, integer: bool) -> SliderRange:
    """A slider range for a field without `@slider`: from 0 to twice the value (mirrored if
    negative)."""
    if integer:
        reach = max(10, 2 * abs(int(value)))
        return SliderRange(0, reach, 1) if value >= 0 else SliderRange(-reach, 0, 1)
    reach = 2.0 * abs(value) if value != 0 else 1.0
    return SliderRange(0.0, reach) if value >= 0 else SliderRange(-reach, 0.0)


def nice_step(span: float) -> float:
    """The largest of 1, 2 or 5 times a power of ten that cuts `span` into at least 100 steps."""
    if not span > 0:
        return 0.01
    raw = span / 100.0
    power = 10.0 ** math.floor(math.log10(raw))
    return max(m * power for m in (1.0, 2.0, 5.0) if m * power <= raw * (1 + 1e-9))


def check_slider_range(
    name: str, handles: list[Any], values: list[Any], indexed: bool, flag: str | None
) -> None:
    """Refuse `values` (one per handle of field `name`'s widgets, entry i of an array if `indexed`)
    where one lies outside its slider's range (which includes the value in force: a range widened to
    a value set elsewhere keeps it). `flag` is the command-line option that sets the field, named in
    the message.

    Raises ConfigError, e.g. "horizon 19 is outside the slider's 0.05 to 5; set a larger value with
    --config or --controller.horizon".
    """
    for i, (handle, value) in enumerate(zip(handles, values, strict=True)):
        if not isinstance(handle, viser.GuiSliderHandle) or handle.min <= value <= handle.max:
            continue
        what = f"{name}[{i}]" if indexed else name
        where = f"--config or {flag}" if flag is not None else "--config or on the command line"
        raise ConfigError(
            f"{what} {format_number(value)} is outside the slider's {format_number(handle.min)} to "
            f"{format_number(handle.max)}; set a "
            f"{'larger' if value > handle.max else 'smaller'} value with {where}"
        )
