"""A GUI folder of widgets generated from a config dataclass, one widget per field.

    int, float   -> slider, over the field's `@slider` range or a default one around the value
    bool         -> checkbox
    Literal[...] -> dropdown of the literal's values
    str          -> text box
    np_1d_field  -> folder with one slider per entry (named and ranged by the field's metadata)
Other field types get no widget. Every range is widened to include the current value.
"""

import math
import threading
import typing
from collections.abc import Callable
from dataclasses import fields
from typing import Any, Literal

import numpy as np
import viser

from judo.core.config import Config, field_types
from judo.core.errors import JudoError
from judo.core.fields import SliderRange, array_field_spec, slider_ranges
from judo.runtime.gui.field_docs import field_docs

EditFn = Callable[[dict[str, Any]], Config]
"""Applies {field: value} and returns the accepted config, or raises JudoError to refuse it."""


class ConfigPanel:
    """Widgets for every supported field of `config`, in a folder titled `label`.

    A user's change calls `on_edit({field: value})`. If that raises JudoError, the widget goes back
    to the last accepted value (the caller reports why). `show(config)` puts a config that changed
    elsewhere (reset, switch) into the widgets without calling `on_edit`. `ranges` ({field: SliderRange})
    replaces the config class's own `@slider` ranges, e.g. a wider num_rollouts on a GPU backend.
    """

    def __init__(
        self,
        gui: viser.GuiApi,
        label: str,
        config: Config,
        on_edit: EditFn,
        order: float,
        ranges: dict[str, SliderRange] | None = None,
    ) -> None:
        self._on_edit = on_edit
        self._config = config
        self._lock = threading.Lock()
        self._widgets: dict[str, list[Any]] = {}
        self._decode: dict[str, Callable[[list[Any]], Any]] = {}
        self._encode: dict[str, Callable[[Any], list[Any]]] = {}
        self.folder = gui.add_folder(label, order=order)
        cls = type(config)
        docs, types = field_docs(cls), field_types(cls)
        ranges = {**slider_ranges(cls), **(ranges or {})}
        with self.folder:
            for f in fields(config):
                self._add_field(
                    gui, f.name, types[f.name], getattr(config, f.name), ranges.get(f.name), docs.get(f.name)
                )

    @property
    def field_names(self) -> list[str]:
        """The fields that have widgets, in declaration order."""
        return list(self._widgets)

    def handles(self, name: str) -> list[Any]:
        """The viser handles of field `name`: one widget, or one slider per entry of an array."""
        return list(self._widgets[name])

    def value_of(self, name: str) -> Any:
        """The value the widgets of field `name` show now."""
        return self._decode[name]([handle.value for handle in self._widgets[name]])

    def show(self, config: Config) -> None:
        """Put `config`'s values into the widgets; nothing is sent back to `on_edit`."""
        with self._lock:
            self._config = config
            for name in self._widgets:
                self._write(name, getattr(config, name))

    def remove(self) -> None:
        """Take the folder and its widgets off the page."""
        self.folder.remove()

    # ---- building ------------------------------------------------------------------------------
    def _add_field(self, gui: viser.GuiApi, name: str, hint: Any, value: Any, rng: SliderRange | None, doc: str | None):
        if hint is bool:
            handles = [gui.add_checkbox(name, bool(value), hint=doc)]
            self._bind(name, handles, lambda values: bool(values[0]), lambda v: [bool(v)])
        elif typing.get_origin(hint) is Literal:
            choices = {str(choice): choice for choice in typing.get_args(hint)}
            handles = [gui.add_dropdown(name, list(choices), initial_value=str(value), hint=doc)]
            self._bind(name, handles, lambda values: choices[values[0]], lambda v: [str(v)])
        elif hint is int or hint is float:
            handles = [_slider(gui, name, value, rng, hint is int, doc)]
            self._bind(name, handles, lambda values: values[0], lambda v: [v])
        elif hint is str:
            handles = [gui.add_text(name, str(value), hint=doc)]
            self._bind(name, handles, lambda values: values[0], lambda v: [v])
        elif hint is np.ndarray and np.ndim(value) == 1:
            handles = self._add_array(gui, name, np.asarray(value, dtype=float), doc)
            self._bind(name, handles, lambda values: np.array(values, dtype=float), lambda v: [float(x) for x in v])

    def _add_array(self, gui: viser.GuiApi, name: str, value: np.ndarray, doc: str | None) -> list[Any]:
        spec = array_field_spec(type(self._config), name)
        spans = 2.0 * np.abs(value) + 1.0
        names = spec.names if spec else [str(i) for i in range(len(value))]
        mins = spec.mins if spec else list(-spans)
        maxs = spec.maxs if spec else list(spans)
        steps = spec.steps if spec else [0.01] * len(value)
        with gui.add_folder(name, expand_by_default=True):
            return [
                _slider(gui, entry, float(x), SliderRange(lo, hi, step), False, doc)
                for entry, x, lo, hi, step in zip(names, value, mins, maxs, steps, strict=True)
            ]

    def _bind(self, name: str, handles: list[Any], decode: Callable, encode: Callable) -> None:
        self._widgets[name], self._decode[name], self._encode[name] = handles, decode, encode
        for handle in handles:
            handle.on_update(lambda event, name=name: self._edited(name, event))

    # ---- editing -------------------------------------------------------------------------------
    def _edited(self, name: str, event: viser.GuiEvent) -> None:
        if event.client is None:  # our own write (show, or a refused edit put back)
            return
        with self._lock:
            value = self.value_of(name)
            try:
                self._config = self._on_edit({name: value})
            except JudoError:
                try:
                    self._write(name, getattr(self._config, name))
                except RuntimeError:  # the panel was removed meanwhile (a switch): nothing to put back
                    pass

    def _write(self, name: str, value: Any) -> None:
        for handle, item in zip(self._widgets[name], self._encode[name](value), strict=True):
            if isinstance(handle, viser.GuiSliderHandle):
                handle.min, handle.max = min(handle.min, item), max(handle.max, item)
            handle.value = item


def _slider(gui: viser.GuiApi, label: str, value: Any, rng: SliderRange | None, integer: bool, doc: str | None):
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
    """A slider range for a field without `@slider`: from 0 to twice the value (mirrored if negative)."""
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
