"""ConfigPanel: one widget per config field, of the kind its type asks for, with @slider ranges."""

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pytest
import viser

from judo.core.configuration.config import Config
from judo.core.configuration.fields import np_1d_field, slider
from judo.core.configuration.registry import config_flag, default_configs
from judo.core.errors import ConfigError
from judo.runtime.gui.config_panel import ConfigPanel
from judo.runtime.gui.field_widgets import (
    check_slider_range,
    default_range,
    format_number,
    nice_step,
    parse_number,
)
from judo.runtime.launch import parse


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
    goal: np.ndarray = np_1d_field(
        [0.1, -0.2], names=["x", "y"], mins=[-1, -1], maxs=[1, 1], steps=[0.05, 0.05]
    )
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
    panel = ConfigPanel(
        server.gui, "Demo", DemoConfig(), lambda updates: edits.append(updates), order=1
    )
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
    assert (
        isinstance(mode, viser.GuiDropdownHandle)
        and mode.options == ("fast", "slow")
        and mode.value == "slow"
    )
    assert isinstance(widgets(panel, "label")[0], viser.GuiTextHandle)
    assert [w.label for w in widgets(panel, "goal")] == ["x", "y"]
    assert [w.label for w in widgets(panel, "weights")] == ["0", "1", "2"]


def test_sliders_use_the_declared_range_widened_to_the_value_or_a_default_one(panel):
    rollouts = widgets(panel, "rollouts")[0]
    assert (rollouts.min, rollouts.max, rollouts.step, rollouts.value) == (1, 64, 1, 16)
    assert isinstance(rollouts.value, int)
    gain = widgets(panel, "gain")[0]
    # widened to hold 3.0
    assert (gain.min, gain.max, gain.step, gain.value) == (0.0, 3.0, 0.5, 3.0)
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


def test_a_value_outside_a_sliders_range_is_refused_naming_the_range_and_the_option_that_sets_it(
    panel,
):
    def check(name, values, flag=None):
        check_slider_range(name, widgets(panel, name), values, name in ("goal", "weights"), flag)

    check("rollouts", [64])  # the ends are in range
    check("rollouts", [1])
    with pytest.raises(ConfigError) as refused:  # 1e9 typed into a slider's box arrives as 19
        check("rollouts", [65], "--optimizer-config.rollouts")
    assert str(refused.value) == (
        "rollouts 65 is outside the slider's 1 to 64; set a larger value with --config or "
        "--optimizer-config.rollouts"
    )
    check("gain", [3.0])  # a range widened to a value set elsewhere keeps it
    with pytest.raises(
        ConfigError,
        match=r"^gain 3.5 is outside the slider's 0 "
        r"to 3; set a larger value with --config ",
    ):
        check("gain", [3.5])
    with pytest.raises(
        ConfigError,
        match=r"^free_float -0.1 is outside the "
        r"slider's 0 to 0.5; set a smaller value",
    ):
        check("free_float", [-0.1])
    check("goal", [1.0, -1.0])  # each entry of an array against its own slider
    with pytest.raises(
        ConfigError,
        match=r"^goal\[1\] -1.5 is outside the slider's -1 to 1; set a smaller value with "
        r"--config or on the command line$",
    ):
        check("goal", [0.0, -1.5])
    check("label", ["any text"])  # only sliders have a range
    # a value set elsewhere widens the slider, which then takes it
    panel.show(DemoConfig(rollouts=100))
    check("rollouts", [100])


def test_a_refusal_names_the_command_line_option_that_really_sets_the_field():
    flags = {
        kind: config_flag(kind, field)
        for kind, field in (("controller", "max_plan_age"), ("optimizer", "num_nodes"))
    }
    assert flags == {
        "controller": "--controller.max-plan-age",
        "optimizer": "--optimizer-config.num-nodes",
    }
    _, configs = parse(
        [flags["controller"], "0", flags["optimizer"], "6"], default_configs("cartpole", "mppi")
    )
    assert (configs["controller"].max_plan_age, configs["optimizer"].num_nodes) == (0.0, 6)


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
    from judo.core.configuration.fields import slider_ranges

    ranges = slider_ranges(LogConfig)
    assert ranges["temperature"].is_log and not ranges["weight"].is_log
    applied: list[dict] = []

    def on_edit(updates):
        applied.append(updates)
        return LogConfig(**{**vars(LogConfig()), **updates})

    panel = ConfigPanel(server.gui, "Log", LogConfig(), on_edit, order=2)
    try:
        (number,) = panel.handles("temperature")  # one widget: no second slider over log10
        # a page sends any text typed
        assert isinstance(number, viser.GuiTextHandle) and number.value == "0.1"
        assert number.hint.endswith("(usually 0.001 to 10; type e.g. 1e-3)")
        number.value = "1e-2"
        assert panel.value_of("temperature") == 0.01
        number.value = "abc"
        with pytest.raises(
            ConfigError, match="temperature must be a number, like 0.25 or 1e-3; got 'abc'"
        ):
            panel.value_of("temperature")
        assert len(panel.handles("weight")) == 1
    finally:
        panel.remove()


def test_a_log_fields_box_shows_numbers_briefly_and_exactly():
    assert [format_number(v) for v in (20.0, 0.3, 1e-5, 0.1 + 0.2)] == [
        "20",
        "0.3",
        "1e-05",
        "0.30000000000000004",
    ]
    assert parse_number("sigma", " 2.5e-3 ") == 0.0025
    with pytest.raises(ConfigError, match="sigma must be a number, like 0.25 or 1e-3; got ''"):
        parse_number("sigma", "")
