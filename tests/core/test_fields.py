"""`@slider` checks its field name when the class is defined, above or below `@dataclass`."""

from dataclasses import dataclass

import pytest

import judo
from judo.core.configuration.fields import slider_ranges

TYPO = (
    "@slider('nmae', ...) on Cfg: Cfg has no field 'nmae' (did you mean 'name'?); "
    "expected one of its fields: name, gain"
)


def test_a_slider_on_a_misspelt_field_above_dataclass_raises_listing_the_fields():
    with pytest.raises(judo.ConfigError) as caught:

        @judo.slider("nmae", 0.0, 1.0)
        @dataclass
        class Cfg(judo.TaskConfig):
            name: float = 0.5
            gain: float = 1.0

    assert str(caught.value) == TYPO


def test_a_slider_on_a_misspelt_field_below_dataclass_raises_the_same():
    with pytest.raises(judo.ConfigError) as caught:

        @dataclass
        @judo.slider("nmae", 0.0, 1.0)
        class Cfg(judo.TaskConfig):
            name: float = 0.5
            gain: float = 1.0

    assert str(caught.value) == TYPO


def test_a_name_with_no_close_field_gets_no_guess():
    with pytest.raises(
        judo.ConfigError,
        match=r"has no field 'zzz'; expected "
        r"one of its fields: w_goal$",
    ):

        @judo.slider("zzz", 0.0, 1.0)
        @dataclass
        class Other(judo.TaskConfig):
            w_goal: float = 1.0


def test_a_slider_below_dataclass_or_on_an_inherited_field_is_kept():
    @dataclass
    @judo.slider("gain", 0.0, 10.0)
    class Base(judo.TaskConfig):
        gain: float = 1.0

    @judo.slider("gain", 0.0, 20.0)
    @judo.slider("extra", 0.0, 3.0)
    @dataclass
    class Child(Base):
        extra: float = 2.0

    assert slider_ranges(Base)["gain"].max == 10.0
    assert slider_ranges(Child)["gain"].max == 20.0 and slider_ranges(Child)["extra"].max == 3.0
