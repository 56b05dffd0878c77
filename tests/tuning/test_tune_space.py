"""The search space: slider ranges, log vs linear, ints, --params / --fix parsing, and the errors
that list valid fields."""

import pytest

import judo
from judo.core.configuration.config_values import SearchSpaceError, apply_values
from judo.core.configuration.registry import default_configs
from judo.tuning.space import Param, build_space, parse_fixed
from tests.conftest import UprightConfig, UprightTask


def by_name(space: list[Param]) -> dict[str, Param]:
    return {param.name: param for param in space}


def test_the_default_space_is_the_optimizers_slider_fields_plus_the_horizon():
    space = by_name(build_space("cartpole", "mppi"))
    assert list(space) == [
        "optimizer.num_rollouts",
        "optimizer.num_nodes",
        "optimizer.sigma",
        "optimizer.temperature",
        "controller.horizon",
    ]  # no noise_ramp: cartpole's use_noise_ramp is off


def test_noise_ramp_is_searched_when_the_ramp_is_on():
    assert "optimizer.noise_ramp" in by_name(build_space("fr3_pick", "ps"))
    assert "optimizer.noise_ramp" in by_name(
        build_space("cartpole", "ps", fixed={"optimizer.use_noise_ramp": True})
    )


MPPI_SLIDERS = [
    "optimizer.num_nodes",
    "optimizer.sigma",
    "optimizer.temperature",
    "controller.horizon",
]


def test_the_default_space_is_three_times_either_side_of_the_value_in_force_on_a_log_scale():
    # cartpole: 64 rollouts, 4 knots, 1.0 s; cem sigma_min 0.2
    space = by_name(build_space("cartpole", "cem"))
    rollouts, nodes, horizon = (
        space["optimizer.num_rollouts"],
        space["optimizer.num_nodes"],
        space["controller.horizon"],
    )
    # ceil(64/3), 192
    assert (rollouts.low, rollouts.high, rollouts.integer, rollouts.log) == (22, 192, True, True)
    assert (nodes.low, nodes.high) == (4, 12)  # 4/3 raised to the 4 knots a cubic spline needs
    assert (horizon.low, horizon.high, horizon.log) == (
        pytest.approx(1 / 3),
        pytest.approx(3.0),
        True,
    )
    assert (space["optimizer.sigma_min"].low, space["optimizer.sigma_min"].high) == pytest.approx(
        (0.2 / 3, 0.6)
    )
    sigma_max = space["optimizer.sigma_max"]  # 1.0: x3 is clipped to the slider's 2.0
    assert (sigma_max.low, sigma_max.high) == pytest.approx((1 / 3, 2.0))
    assert all(param.log for param in space.values())
    tuned = by_name(
        build_space("cartpole", "cem", ["controller.horizon", "optimizer.num_elites=1:4"])
    )
    # --params: slider
    assert (tuned["controller.horizon"].low, tuned["controller.horizon"].high) == (0.05, 5.0)
    assert (tuned["optimizer.num_elites"].low, tuned["optimizer.num_elites"].high) == (1, 4)


def test_ranges_of_two_decades_or_more_are_log_and_narrower_ones_linear():
    space = by_name(build_space("cartpole", "mppi", MPPI_SLIDERS))
    temperature = space["optimizer.temperature"]
    assert (temperature.low, temperature.high, temperature.log, temperature.integer) == (
        0.001,
        10.0,
        True,
        False,
    )
    assert space["optimizer.sigma"].log  # 0.001 to 2
    assert space["controller.horizon"].log  # 0.05 to 5: exactly two decades
    num_nodes = space["optimizer.num_nodes"]
    assert (num_nodes.log, num_nodes.integer) == (False, True)  # 2 (here 4) to 20
    dial = by_name(
        build_space("cartpole", "dial", ["optimizer.temperature", "optimizer.beta_opt_iter"])
    )
    assert dial["optimizer.temperature"].log  # 0.01 to 5: 2.7 decades
    assert dial["optimizer.beta_opt_iter"].log  # 0.05 to 5: exactly two decades
    icem = by_name(build_space("cartpole", "icem", ["optimizer.elite_keep_fraction"]))
    assert not icem["optimizer.elite_keep_fraction"].log  # starts at 0


def test_int_fields_stay_ints_and_num_nodes_starts_where_the_spline_order_needs():
    # cubic: 4+
    space = by_name(
        build_space("cartpole", "ps", ["optimizer.num_rollouts", "optimizer.num_nodes"])
    )
    rollouts, nodes = space["optimizer.num_rollouts"], space["optimizer.num_nodes"]
    assert (rollouts.low, rollouts.high, rollouts.integer, rollouts.log) == (1, 512, True, True)
    assert (nodes.low, nodes.high) == (4, 20)
    linear = by_name(
        build_space(
            "cartpole", "ps", ["optimizer.num_nodes"], fixed={"controller.spline_order": "linear"}
        )
    )
    assert linear["optimizer.num_nodes"].low == 2


def test_params_restrict_and_extend_the_space_with_ranges_and_choices():
    space = by_name(
        build_space(
            "cartpole",
            "mppi",
            [
                "optimizer.temperature=0.01:0.5",
                "task.w_centered",
                "controller.spline_order",
                "controller.horizon",
            ],
        )
    )
    assert list(space) == [
        "optimizer.temperature",
        "task.w_centered",
        "controller.spline_order",
        "controller.horizon",
    ]
    assert (space["optimizer.temperature"].low, space["optimizer.temperature"].high) == (0.01, 0.5)
    assert space["optimizer.temperature"].log is False  # 1.7 decades
    assert space["controller.spline_order"].choices == ("zero", "linear", "cubic")


def test_fixed_fields_are_parsed_typed_and_left_out_of_the_space():
    configs = default_configs("cartpole", "mppi")
    fixed = parse_fixed(
        ["optimizer.num_rollouts=64", "optimizer.sigma=0.25", "controller.spline_order=linear"],
        configs,
    )
    assert fixed == {
        "optimizer.num_rollouts": 64,
        "optimizer.sigma": 0.25,
        "controller.spline_order": "linear",
    }
    assert isinstance(fixed["optimizer.sigma"], float)
    space = by_name(build_space("cartpole", "mppi", fixed=fixed))
    assert "optimizer.num_rollouts" not in space and "optimizer.sigma" not in space
    applied = apply_values(configs, fixed)
    assert applied["optimizer"].num_rollouts == 64  # type: ignore[attr-defined]


def test_an_unknown_field_lists_the_valid_ones():
    with pytest.raises(SearchSpaceError) as error:
        build_space("cartpole", "mppi", ["optimizer.temprature"])
    message = str(error.value)
    assert message.startswith(
        "unknown parameter 'optimizer.temprature': expected "
        "<controller|optimizer|task>.<field>; valid parameters are: "
    )
    assert (
        "optimizer.temperature" in message
        and "controller.horizon" in message
        and "task.w_centered" in message
    )
    with pytest.raises(SearchSpaceError, match=r"unknown parameter 'policy.sigma'"):
        parse_fixed(["policy.sigma=0.1"], default_configs("cartpole", "mppi"))


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        (
            "optimizer.num_rollouts",
            r"--fix 'optimizer.num_rollouts': expected <kind>.<field>=VALUE",
        ),
        (
            "optimizer.num_rollouts=6.5",
            r"--fix 'optimizer.num_rollouts=6.5': MPPIConfig.num_rollouts expects an integer",
        ),
        (
            "controller.spline_order=quintic",
            r"expects one of \['zero', "
            r"'linear', 'cubic'\], got 'quintic'",
        ),
    ],
)
def test_bad_fixed_values_say_what_was_expected(entry, message):
    with pytest.raises(SearchSpaceError, match=message):
        parse_fixed([entry], default_configs("cartpole", "mppi"))


def test_bad_ranges_and_fields_without_a_slider_are_refused():
    with pytest.raises(SearchSpaceError, match=r"expected optimizer.sigma=LOW:HIGH"):
        build_space("cartpole", "mppi", ["optimizer.sigma=0.1"])
    with pytest.raises(SearchSpaceError, match=r"low \(1\) must be below its high \(0.1\)"):
        build_space("cartpole", "mppi", ["optimizer.sigma=1:0.1"])
    judo.register_task("tune_space_upright", UprightTask, UprightConfig)  # w_upright has no slider
    with pytest.raises(
        SearchSpaceError,
        match=r"^task.w_upright has no @slider range; "
        r"give one as task.w_upright=LOW:HIGH$",
    ):
        build_space("tune_space_upright", "ps", ["task.w_upright"])
    space = build_space("tune_space_upright", "ps", ["task.w_upright=0.5:2"])
    assert (space[0].low, space[0].high) == (0.5, 2.0)
