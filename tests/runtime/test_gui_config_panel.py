"""ConfigPanel: one widget per config field, of the kind its type asks for, with @slider ranges."""

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pytest
import viser

from judo.core.config import Config
from judo.core.errors import ConfigError
from judo.core.fields import np_1d_field, slider
from judo.runtime.gui.config_panel import ConfigPanel, default_range, format_number, nice_step, parse_number


@slider("rollouts", 1, 64, 1)
@slider("gain", 0.0, 2.0, 0.5)
@dataclass
class DemoConfig(Config):
    """Every kind of field the GUI knows, and one it does not."""

    rollouts: int = 16
    """Rollouts per cycle."""
    gain: float = 3.0
    """Outside its slider range on purpose."""
    free_float: float = 0.25
    """No @slider: a default range."""
    free_int: int = 7
    """No @slider either."""
    enabled: bool = True
    """A checkbox."""
    mode: Literal["fast", "slow"] = "slow"
    """A dropdown."""
    label: str = "demo"
    """A text box."""
    goal: np.ndarray = np_1d_field([0.1, -0.2], names=["x", "y"], mins=[-1, -1], maxs=[1, 1], steps=[0.05, 0.05])
    """A named array."""
    weights: np.ndarray = field(default_factory=lambda: np.array([1.0, 2.0, 3.0]))
    """An array without np_1d_field metadata."""
    table: dict = field(default_factory=dict)
    """Not a GUI type: no widget."""


@pytest.fixture(scope="module")
def server():
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield server
    server.stop()


@pytest.fixture
def panel(server):
    edits = []
    panel = ConfigPanel(server.gui, "Demo", DemoConfig(), lambda updates: edits.append(updates), order=1)
    yield panel
    panel.remove()


def widgets(panel: ConfigPanel, name: str):
    return panel.handles(name)


def test_each_supported_field_gets_the_widget_its_type_asks_for(panel):
    assert panel.field_names == [
        "rollouts", "gain", "free_float", "free_int", "enabled", "mode", "label", "goal", "weights",
    ]  # fmt: skip
    assert isinstance(widgets(panel, "rollouts")[0], viser.GuiSliderHandle)
    assert isinstance(widgets(panel, "enabled")[0], viser.GuiCheckboxHandle)
    mode = widgets(panel, "mode")[0]
    assert isinstance(mode, viser.GuiDropdownHandle) and mode.options == ("fast", "slow") and mode.value == "slow"
    assert isinstance(widgets(panel, "label")[0], viser.GuiTextHandle)
    assert [w.label for w in widgets(panel, "goal")] == ["x", "y"]
    assert [w.label for w in widgets(panel, "weights")] == ["0", "1", "2"]


def test_sliders_use_the_declared_range_widened_to_the_value_or_a_default_one(panel):
    rollouts = widgets(panel, "rollouts")[0]
    assert (rollouts.min, rollouts.max, rollouts.step, rollouts.value) == (1, 64, 1, 16)
    assert isinstance(rollouts.value, int)
    gain = widgets(panel, "gain")[0]
    assert (gain.min, gain.max, gain.step, gain.value) == (0.0, 3.0, 0.5, 3.0)  # widened to hold 3.0
    free_float = widgets(panel, "free_float")[0]
    assert (free_float.min, free_float.max, free_float.step) == (0.0, 0.5, 0.005)
    free_int = widgets(panel, "free_int")[0]
    assert (free_int.min, free_int.max, free_int.step) == (0, 14, 1)
    x, y = widgets(panel, "goal")
    assert (x.min, x.max, x.step, x.value, y.value) == (-1.0, 1.0, 0.05, 0.1, -0.2)
    assert widgets(panel, "weights")[2].max == 7.0  # np_1d_field's default span, 2 |v| + 1


def test_field_names_in_words_become_labels_and_the_exact_name_and_docstring_hover_hints(panel):
    assert widgets(panel, "rollouts")[0].hint == "rollouts: Rollouts per cycle."
    assert widgets(panel, "goal")[1].hint == "goal: A named array."
    free_float = widgets(panel, "free_float")[0]
    assert free_float.label == "free float" and free_float.hint.startswith("free_float")


def test_show_puts_a_config_into_the_widgets_and_widens_ranges(panel):
    config = DemoConfig(rollouts=100, mode="fast", enabled=False, goal=np.array([0.5, 0.5]))
    panel.show(config)
    assert widgets(panel, "rollouts")[0].max == 100 and panel.value_of("rollouts") == 100
    assert panel.value_of("mode") == "fast" and panel.value_of("enabled") is False
    np.testing.assert_array_equal(panel.value_of("goal"), [0.5, 0.5])


@pytest.mark.parametrize(
    ("value", "integer", "expected"),
    [
        (0.25, False, (0.0, 0.5)),
        (-3.0, False, (-6.0, 0.0)),
        (0.0, False, (0.0, 1.0)),
        (40, True, (0, 80)),
        (-2, True, (-10, 0)),
    ],
)
def test_default_range_reaches_twice_the_value(value, integer, expected):
    rng = default_range(value, integer)
    assert (rng.min, rng.max) == expected


def test_nice_step_cuts_a_span_into_at_least_100_round_steps():
    assert [nice_step(span) for span in (1.0, 0.5, 3.0, 250.0)] == [0.01, 0.005, 0.02, 2.0]


@slider("temperature", 0.001, 10.0, 0.001)
@slider("weight", 0.0, 500.0, 1.0)
@dataclass
class LogConfig(Config):
    """A field over four decades and one from zero."""

    temperature: float = 0.1
    """Spans 0.001 to 10: a log slider."""
    weight: float = 30.0
    """Starts at 0: a linear slider."""


def test_a_range_over_two_decades_gets_one_box_in_real_units(server):
    from judo.core.fields import slider_ranges

    ranges = slider_ranges(LogConfig)
    assert ranges["temperature"].is_log and not ranges["weight"].is_log
    applied: list[dict] = []

    def on_edit(updates):
        applied.append(updates)
        return LogConfig(**{**vars(LogConfig()), **updates})

    panel = ConfigPanel(server.gui, "Log", LogConfig(), on_edit, order=2)
    try:
        (number,) = panel.handles("temperature")  # one widget: no second slider over log10
        assert isinstance(number, viser.GuiTextHandle) and number.value == "0.1"  # a page sends any text typed
        assert number.hint.endswith("(usually 0.001 to 10; type e.g. 1e-3)")
        number.value = "1e-2"
        assert panel.value_of("temperature") == 0.01
        number.value = "abc"
        with pytest.raises(ConfigError, match="temperature must be a number, like 0.25 or 1e-3; got 'abc'"):
            panel.value_of("temperature")
        assert len(panel.handles("weight")) == 1
    finally:
        panel.remove()


def test_a_log_fields_box_shows_numbers_briefly_and_exactly():
    assert [format_number(v) for v in (20.0, 0.3, 1e-5, 0.1 + 0.2)] == ["20", "0.3", "1e-05", "0.30000000000000004"]
    assert parse_number("sigma", " 2.5e-3 ") == 0.0025
    with pytest.raises(ConfigError, match="sigma must be a number, like 0.25 or 1e-3; got ''"):
        parse_number("sigma", "")
