"""A GUI folder of widgets generated from a config dataclass, one widget per field.

    int, float   -> slider, over the field's `@slider` range or a default one around the value
    float over decades (log range) -> one text box in real units (typed: 1e-3), its range in the hint
    bool         -> checkbox
    Literal[...] -> dropdown of the literal's values
    str          -> text box
    np_1d_field  -> folder with one slider per entry (named and ranged by the field's metadata)
Other field types get no widget. Every range is widened to include the current value. A widget is
labelled with its field's name in words (`field_label`: "max num traces"), and its hover hint
starts with the exact name.

A page sends a number box's value at every keystroke and a slider's at every step of a drag, so an
edit is applied once it has settled (EDIT_SETTLE seconds without a change): typing 0.001 never
applies 0. A value typed into a slider's box outside the slider's range is refused with a message
naming the range and the command-line option that sets it: the box drops letters, so `1e9` arrives
as 19, and the server cannot tell it from a 19 typed on purpose. After each applied edit, accepted
or refused, every page is made to show the value in force, even one whose box holds stale text.
"""  # noqa: E501

import functools
import threading
import time
import typing
from collections.abc import Callable
from dataclasses import fields
from typing import Any, Literal

import numpy as np
import viser

from judo.core.configuration.config import Config, field_types
from judo.core.configuration.field_docs import field_docs
from judo.core.configuration.fields import SliderRange, array_field_spec, slider_ranges
from judo.core.configuration.registry import config_flag
from judo.core.errors import JudoError
from judo.runtime.gui.field_widgets import (
    add_slider,
    check_slider_range,
    encode_log,
    field_hint,
    field_label,
    format_number,
    parse_number,
)

EditFn = Callable[[dict[str, Any]], Config]
"""Applies {field: value} and returns the accepted config, or raises JudoError to refuse it."""
ReportFn = Callable[[str], None]
"""Shows why an edit was refused (on the status line)."""

EDIT_SETTLE = 0.5
"""Seconds a widget must keep its value before the edit is applied."""
REFUSAL_HOLD = 1.5
"""Seconds a refused value stays in its box, unreported, in case the user is still typing (a "0" on
the way to "0.25"); then the refusal is reported and the box goes back to the value in force."""
NUDGE_HOLD = 0.5
"""Seconds an integer nudged by one step to make pages redraw is held before it is put back."""
FLOAT_NUDGE = 1e-9
"""Relative change that makes a page redraw a float box without changing what it means."""


class ConfigPanel:
    """Widgets for every supported field of `config`, in a folder titled `label`.

    A user's change is queued; `flush()` (called every GUI frame) calls `on_edit({field: value})`
    once it has settled. If that raises JudoError, the widget goes back to the last accepted value
    (the caller reports why). `show(config)` puts a config that changed elsewhere (reset, switch, a
    script) into the widgets without calling `on_edit`, widening a slider's range to hold a value
    beyond it. `ranges` ({field: SliderRange}) replaces the config class's own `@slider` ranges,
    e.g. a wider num_rollouts on a GPU backend. The fields in `hidden` get no widget (fields of no
    use to the session, e.g. policy_samples without a proposal policy). A page's value outside a
    slider's range is refused (`check_slider_range`); with `kind` (a key of
    `judo.core.configuration.registry.CONFIG_GROUPS`) the refusal names the command-line option that
    sets the field.
    """

    def __init__(
        self,
        gui: viser.GuiApi,
        label: str,
        config: Config,
        on_edit: EditFn,
        order: float,
        ranges: dict[str, SliderRange] | None = None,
        on_refused: ReportFn | None = None,
        hidden: tuple[str, ...] = (),
        kind: str | None = None,
    ) -> None:
        self._on_edit = on_edit
        self._on_refused = on_refused
        self._kind = kind
        self._arrays: set[str] = set()  # fields shown as one slider per entry
        # field -> (when, why, the widget values refused) of a refusal not yet shown
        self._refused: dict[str, tuple[float, str, list[Any]]] = {}
        self._config = config
        self._lock = threading.Lock()
        self._widgets: dict[str, list[Any]] = {}
        self._decode: dict[str, Callable[[list[Any]], Any]] = {}
        self._encode: dict[str, Callable[[Any], list[Any]]] = {}
        # field -> the widget values seen while it was edited
        self._pending: dict[str, list[list[Any]]] = {}
        self._last_change: dict[str, float] = {}
        # id(handle) -> (handle, value it was nudged to, value in force, when to put it back or
        # None)
        self._nudged: dict[int, tuple[Any, Any, Any, float | None]] = {}
        self.folder = gui.add_folder(label, order=order)
        cls = type(config)
        docs, types = field_docs(cls), field_types(cls)
        ranges = {**slider_ranges(cls), **(ranges or {})}
        with self.folder:
            for f in fields(config):
                if f.name in hidden:
                    continue
                self._add_field(
                    gui,
                    f.name,
                    types[f.name],
                    getattr(config, f.name),
                    ranges.get(f.name),
                    docs.get(f.name),
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
        return self._decode[name]([self._shown(handle) for handle in self._widgets[name]])

    def show(self, config: Config, redraw: bool = False) -> None:
        """Put `config`'s values into the widgets on every page; nothing is sent back to `on_edit`.

        With `redraw`, every page redraws even the values that did not change (after Reset configs,
        so a box left blank shows the value in force again).
        """
        with self._lock:
            self._config = config
            self._pending.clear()
            for name in self._widgets:
                self._write(name, getattr(config, name), resync=redraw)

    def flush(self) -> None:
        """Apply the edits that have settled, and put back the values nudged long enough ago."""
        with self._lock:
            now = time.monotonic()
            for key, (handle, nudged, value, when) in list(self._nudged.items()):
                if when is None or now - when < NUDGE_HOLD:
                    continue
                del self._nudged[key]
                if handle.value == nudged:  # a page may have edited it since
                    handle.value = value
            for name in [n for n, t in self._last_change.items() if now - t >= EDIT_SETTLE]:
                del self._last_change[name]
                seen = self._settled(name, self._pending.pop(name))
                if self._echoes_refusal(name, seen):
                    # a box put a refused value back to its slider's end: the refusal stands
                    continue
                self._refused.pop(name, None)
                try:
                    flag = config_flag(self._kind, name) if self._kind is not None else None
                    check_slider_range(name, self._widgets[name], seen, name in self._arrays, flag)
                    self._config = self._on_edit({name: self._decode[name](seen)})
                except JudoError as err:
                    # shown and put back once the user stops typing
                    self._refused[name] = (now, str(err), seen)
                    continue
                self._write(name, getattr(self._config, name), resync=True)
            for name, (when, why, _) in list(self._refused.items()):
                if now - when >= REFUSAL_HOLD and name not in self._last_change:
                    del self._refused[name]
                    if self._on_refused is not None:
                        self._on_refused(why)
                    self._write(name, getattr(self._config, name), resync=True)

    def remove(self) -> None:
        """Take the folder and its widgets off the page."""
        self.folder.remove()

    # ---- building ------------------------------------------------------------------------------
    def _add_field(
        self,
        gui: viser.GuiApi,
        name: str,
        hint: Any,
        value: Any,
        rng: SliderRange | None,
        doc: str | None,
    ):
        label, doc = field_label(name), field_hint(name, doc)
        if hint is bool:
            handles = [gui.add_checkbox(label, bool(value), hint=doc)]
            self._bind(name, handles, lambda values: bool(values[0]), lambda v: [bool(v)])
        elif typing.get_origin(hint) is Literal:
            choices = {str(choice): choice for choice in typing.get_args(hint)}
            handles = [gui.add_dropdown(label, list(choices), initial_value=str(value), hint=doc)]
            self._bind(name, handles, lambda values: choices[values[0]], lambda v: [str(v)])
        elif hint is float and rng is not None and rng.is_log and value > 0:
            handles = self._add_log(gui, label, float(value), rng, doc)
            self._bind(name, handles, functools.partial(self._decode_log, name), encode_log)
        elif hint is int or hint is float:
            handles = [add_slider(gui, label, value, rng, hint is int, doc)]
            self._bind(name, handles, lambda values: values[0], lambda v: [v])
        elif hint is str:
            handles = [gui.add_text(label, str(value), hint=doc)]
            self._bind(name, handles, lambda values: values[0], lambda v: [v])
        elif hint is np.ndarray and np.ndim(value) == 1:
            handles = self._add_array(gui, name, np.asarray(value, dtype=float), doc)
            self._bind(
                name,
                handles,
                lambda values: np.array(values, dtype=float),
                lambda v: [float(x) for x in v],
            )

    def _add_log(
        self, gui: viser.GuiApi, label: str, value: float, rng: SliderRange, doc: str
    ) -> list[Any]:
        """One box for the value in real units (a field over decades: typed, e.g. 1e-3), its range
        in the hint.

        The box is a text box: a page sends whatever is typed there, so text that is not a number is
        refused with a message and replaced by the value in force (a page's number box sends nothing
        for it and is left blank).
        """
        span = f"{format_number(min(rng.min, value))} to {format_number(max(rng.max, value))}"
        return [
            gui.add_text(
                label, format_number(value), hint=f"{doc} (usually {span}; type e.g. 1e-3)"
            )
        ]

    def _decode_log(self, name: str, values: list[Any]) -> float:
        """The value a log field's box asks for. Raises ConfigError when it holds text that is not a
        number."""
        return parse_number(name, values[0])

    def _add_array(self, gui: viser.GuiApi, name: str, value: np.ndarray, doc: str) -> list[Any]:
        spec = array_field_spec(type(self._config), name)
        self._arrays.add(name)
        spans = 2.0 * np.abs(value) + 1.0
        names = spec.names if spec else [str(i) for i in range(len(value))]
        mins = spec.mins if spec else list(-spans)
        maxs = spec.maxs if spec else list(spans)
        steps = spec.steps if spec else [0.01] * len(value)
        with gui.add_folder(field_label(name), expand_by_default=True):
            return [
                add_slider(gui, field_label(entry), float(x), SliderRange(lo, hi, step), False, doc)
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
            self._pending.setdefault(name, []).append(
                [self._shown(handle) for handle in self._widgets[name]]
            )
            self._last_change[name] = time.monotonic()

    def _shown(self, handle: Any) -> Any:
        """The value `handle` shows, or will again at the next flush if it is nudged for a
        redraw."""
        nudged = self._nudged.get(id(handle))
        return nudged[2] if nudged is not None and handle.value == nudged[1] else handle.value

    def _settled(self, name: str, seen: list[list[Any]]) -> list[Any]:
        """The widget values to apply: the last seen, except where a number box clamped a typed
        value.

        A page's number box puts a value typed beyond the slider's range back to the range's end
        when it loses focus; that end, right after a value beyond it, means the typed value (which
        `check_slider_range` then refuses).
        """
        settled = list(seen[-1])
        for i, handle in enumerate(self._widgets[name]):
            if not isinstance(handle, viser.GuiSliderHandle) or settled[i] not in (
                handle.min,
                handle.max,
            ):
                continue
            beyond = [v[i] for v in seen if v[i] > handle.max or v[i] < handle.min]
            if beyond:
                settled[i] = beyond[-1]
        return settled

    def _echoes_refusal(self, name: str, seen: list[Any]) -> bool:
        """True when `seen` is field `name`'s refused values put back to their sliders' ends: a
        page's number box does that when it loses focus, after the refused value reached the app (as
        `_settled` reads it before)."""
        refused = self._refused.get(name)
        if refused is None:
            return False
        ends = [
            min(max(value, handle.min), handle.max)
            if isinstance(handle, viser.GuiSliderHandle)
            else value
            for handle, value in zip(self._widgets[name], refused[2], strict=True)
        ]
        return ends != refused[2] and seen == ends

    def _write(self, name: str, value: Any, resync: bool = False) -> None:
        """Show `value` in field `name`'s widgets, widening slider ranges to hold it.

        With `resync`, every page redraws the value even if the server thinks it shows it already
        (a box left blank or with refused text); a page redraws only on a changed value, so it gets
        one: a float alternates between the value and the value nudged by FLOAT_NUDGE (the same to
        every digit shown), an integer is nudged by one step and put back NUDGE_HOLD seconds later.
        """
        for handle, item in zip(self._widgets[name], self._encode[name](value), strict=True):
            if isinstance(handle, viser.GuiSliderHandle):
                handle.min, handle.max = min(handle.min, item), max(handle.max, item)
            shown = self._nudged.pop(id(handle), None)
            if resync and isinstance(item, float):
                if shown is not None and shown[2] == item and handle.value == shown[1]:
                    handle.value = item  # it shows the nudged value: the exact one is a change
                else:
                    handle.value = item + max(abs(item), 1e-3) * FLOAT_NUDGE
                    self._nudged[id(handle)] = (handle, handle.value, item, None)
            elif resync and isinstance(item, int) and not isinstance(item, bool):
                handle.value = item + (getattr(handle, "step", None) or 1)
                self._nudged[id(handle)] = (handle, handle.value, item, time.monotonic())
            else:
                handle.value = item
