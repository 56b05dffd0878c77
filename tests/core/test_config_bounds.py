"""Finite values and sane bounds at the boundary, and a refused change that leaves the running
layout intact."""

import copy
import dataclasses

import numpy as np
import pytest

import judo
from judo.core.configuration.config import snapshot, with_updates
from judo.core.configuration.controller_config import MAX_ROLLOUT_BYTES, check_configs
from judo.core.configuration.fields import slider_ranges
from judo.core.errors import NonFiniteKnotsError
from judo.optimizers.cem import CEMConfig
from judo.optimizers.mppi import MPPIConfig
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig


def every_config_class() -> list[type[judo.Config]]:
    tasks = [config for _, config in judo.get_registered_tasks().values()]
    optimizers = [config for _, config in judo.get_registered_optimizers().values()]
    return [judo.ControllerConfig, *optimizers, *tasks]


@pytest.mark.parametrize("config_cls", every_config_class(), ids=lambda cls: cls.__name__)
def test_every_numeric_field_refuses_nan_and_inf_naming_the_field(config_cls):
    config = config_cls()
    for field in dataclasses.fields(config):
        value = getattr(config, field.name)
        if isinstance(value, bool) or not isinstance(value, (float, np.ndarray)):
            continue
        for bad in (np.nan, np.inf, -np.inf):
            bad_value = np.full_like(value, bad) if isinstance(value, np.ndarray) else bad
            with pytest.raises(
                judo.ConfigError, match=f"{config_cls.__name__}.{field.name} expects .*finite"
            ):
                with_updates(config, {field.name: bad_value})  # the file, CLI and GUI path
            with pytest.raises(
                judo.ConfigError, match=f"{config_cls.__name__}.{field.name} must .*finite"
            ):
                config_cls(**{field.name: bad_value})


@pytest.mark.parametrize("config_cls", every_config_class(), ids=lambda cls: cls.__name__)
def test_every_slider_range_lies_within_what_validate_accepts(config_cls):
    """A slider's ends pass the field's own range check (a cross-field check, such as num_elites <=
    num_rollouts, may still refuse a combination the user then corrects with the other slider)."""
    for name, bounds in slider_ranges(config_cls).items():
        kind = type(getattr(config_cls(), name))
        for end in (bounds.min, bounds.max):
            try:
                config_cls(**{name: kind(end)})
            except judo.ConfigError as err:
                others = [f.name for f in dataclasses.fields(config_cls) if f.name != name]
                assert any(other in str(err) for other in others), (
                    f"slider of {name} reaches a refused value: {err}"
                )


@pytest.mark.parametrize(
    ("updates", "message"),
    [
        ({"horizon": np.inf}, "ControllerConfig.horizon must be a finite number, got inf"),
        (
            {"control_freq": np.nan},
            "ControllerConfig.control_freq must be a finite number, got nan",
        ),
        ({"horizon": 1e6}, "horizon must be above 0 and at most 60.0 s, got 1000000.0"),
        ({"horizon": -1.0}, "horizon must be above 0 and at most 60.0 s, got -1.0"),
        ({"control_freq": 0.0}, "control_freq must be between 0.1 and 1000.0 Hz, got 0.0"),
        ({"control_freq": 1e-9}, "control_freq must be between 0.1 and 1000.0 Hz, got 1e-09"),
        ({"control_freq": 1e9}, "control_freq must be between 0.1 and 1000.0 Hz, got 1000000000.0"),
        ({"max_opt_iters": 10**6}, "max_opt_iters must be between 1 and 100, got 1000000"),
        ({"max_opt_iters": 0}, "max_opt_iters must be between 1 and 100, got 0"),
        ({"max_num_traces": -1}, "max_num_traces must be between 0 and 64, got -1"),
    ],
)
def test_controller_config_bounds_name_the_valid_range(updates, message):
    with pytest.raises(
        judo.ConfigError, match=f"^{message}$".replace("(", r"\(").replace(")", r"\)")
    ):
        judo.ControllerConfig(**updates)


@pytest.mark.parametrize(
    ("updates", "message"),
    [
        ({"num_rollouts": 10**7}, "num_rollouts must be between 1 and 1048576, got 10000000"),
        ({"num_rollouts": -5}, "num_rollouts must be between 1 and 1048576, got -5"),
        ({"num_nodes": 10**6}, "num_nodes must be between 1 and 100, got 1000000"),
        ({"noise_ramp": 0.0}, "noise_ramp must be above 0 and at most 100.0, got 0.0"),
        ({"sigma": -0.1}, "sigma must be positive, got -0.1"),
        ({"sigma": 0.0}, "sigma must be positive, got 0.0"),
    ],
)
def test_optimizer_config_bounds_name_the_valid_range(updates, message):
    with pytest.raises(judo.ConfigError, match=f"^{message}$"):
        MPPIConfig(**updates)


def test_65536_rollouts_are_allowed_but_buffers_beyond_the_memory_limit_are_refused_before_allocating(  # noqa: E501
    upright_task,
):
    controller_config = judo.ControllerConfig(horizon=1.0)  # 100 steps of the tiny cart-pole
    check_configs(upright_task, controller_config, MPPIConfig(num_rollouts=65536))
    with pytest.raises(
        judo.ConfigError,
        match=r"would need .* GiB of rollout "
        r"buffers, more than the 4 GiB limit",
    ):
        check_configs(
            upright_task, judo.ControllerConfig(horizon=60.0), MPPIConfig(num_rollouts=2**20)
        )
    assert MAX_ROLLOUT_BYTES == 4 * 2**30


def small_controller(task, **optimizer_fields):
    config = PredictiveSamplingConfig(num_rollouts=8, **optimizer_fields)
    optimizer = PredictiveSampling(config, task.nu)
    optimizer.rng = np.random.default_rng(0)
    return judo.Controller(judo.ControllerConfig(horizon=0.3), task, optimizer, num_workers=1)


@pytest.mark.parametrize(
    ("kind", "field", "bad"),
    [
        ("controller", "horizon", np.inf),
        ("optimizer", "num_nodes", 10**6),
        ("optimizer", "num_rollouts", 10**7),
    ],
)
def test_a_refused_live_edit_keeps_the_layout_and_reverting_it_plans_again(
    upright_task, kind, field, bad
):
    """A config edited in place (bypassing validation) is refused each cycle; reverting it resumes
    planning."""
    controller = small_controller(upright_task)
    try:
        state = np.zeros(4)
        controller.update_action(state, 0.0)
        config = controller.config if kind == "controller" else controller.optimizer.config
        good = getattr(config, field)
        setattr(config, field, bad)
        for _ in range(2):
            with pytest.raises(judo.ConfigError, match=field):
                controller.update_action(state, 0.02)
        assert controller.action(0.02).shape == (1,)  # the previous plan is still served
        setattr(config, field, good)
        plan = controller.update_action(state, 0.04)
        assert np.isfinite(plan.knots).all() and plan.knots.shape == (
            controller.optimizer.num_nodes,
            1,
        )
    finally:
        controller.close()


def test_a_nan_sigma_never_reaches_the_plan_and_reverting_it_plans_again(upright_task):
    controller = small_controller(upright_task, sigma=0.3)
    try:
        state = np.zeros(4)
        previous = controller.update_action(state, 0.0).knots.copy()
        controller.optimizer.config.sigma = np.nan  # an in-place edit that skips validation
        with pytest.raises(
            NonFiniteKnotsError, match="sample_control_knots returned non-finite knots"
        ):
            controller.update_action(state, 0.02)
        np.testing.assert_array_equal(controller.nominal_knots, np.clip(previous, -1, 1))
        assert np.isfinite(controller.action(0.03)).all()
        controller.optimizer.config.sigma = 0.3
        plan = controller.update_action(state, 0.04)
        assert np.isfinite(plan.knots).all()
    finally:
        controller.close()


def test_a_cem_whose_search_went_nan_is_restarted(upright_task):
    from judo.optimizers.cem import CEM

    optimizer = CEM(CEMConfig(num_rollouts=8, num_elites=2), upright_task.nu)
    controller = judo.Controller(
        judo.ControllerConfig(horizon=0.3), upright_task, optimizer, num_workers=1
    )
    try:
        controller.update_action(np.zeros(4), 0.0)
        optimizer.sigma[:] = np.nan  # a corrupted carried distribution
        with pytest.raises(NonFiniteKnotsError, match="restarted its search"):
            controller.update_action(np.zeros(4), 0.02)
        assert np.isfinite(controller.update_action(np.zeros(4), 0.04).knots).all()
    finally:
        controller.close()


@pytest.mark.parametrize("config_cls", every_config_class(), ids=lambda cls: cls.__name__)
def test_every_float_field_refuses_a_magnitude_whose_use_overflows(config_cls):
    """1e308 weights, noise or goals pass "finite" but overflow every planning cycle: one bound,
    every field."""
    from judo.core.configuration.config import MAX_MAGNITUDE

    config = config_cls()
    for field in dataclasses.fields(config):
        value = getattr(config, field.name)
        if isinstance(value, bool) or not isinstance(value, (float, np.ndarray)):
            continue
        for bad in (1e308, -1e308, 10 * MAX_MAGNITUDE):
            bad_value = np.full_like(value, bad) if isinstance(value, np.ndarray) else bad
            # by its own range, or else the bound
            with pytest.raises(judo.ConfigError, match=field.name):
                with_updates(config, {field.name: bad_value})
    # fields with no range of their own: the bound names it
    weights = judo.get_registered_tasks()["cartpole"][1]()
    with pytest.raises(
        judo.ConfigError,
        match=r"CartpoleConfig.w_vertical must "
        r"be of magnitude at most 1e\+09",
    ):
        with_updates(weights, {"w_vertical": -1e308})


@pytest.mark.parametrize(
    ("updates", "message"),
    [
        ({"horizon": 10**40}, "horizon must be above 0 and at most 60.0 s, got 1e+40"),
        ({"horizon": 10**400}, "ControllerConfig.horizon expects a finite number, got 1000000"),
        ({"max_opt_iters": 10**40}, "max_opt_iters must be between 1 and 100"),
        (
            {"spline_order": np.array([1, 2])},
            "ControllerConfig.spline_order expects one of ['zero', 'linear', 'cubic']",
        ),
        ({"spline_order": ["cubic"]}, "expects one of"),
        ([1, 2], "updates must be a dict {field: value}, got list [1, 2]"),
        ("horizon", "updates must be a dict {field: value}, got str"),
        ({"horizon": "x" * 10**6}, "expects a number, got 'xxx"),
    ],
)
def test_update_config_raises_config_errors_only_with_values_cut_short(updates, message):
    with pytest.raises(judo.ConfigError) as error:
        with_updates(judo.ControllerConfig(), updates)  # type: ignore[arg-type]
    assert message in str(error.value) and len(str(error.value)) < 400


@dataclasses.dataclass
class _PlainConfig(judo.TaskConfig):
    gain: float = 1.0
    goal: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(2))


class _CopyHookConfig(_PlainConfig):
    def __copy__(self):  # a hook that copy.copy honours, so snapshot does too
        return _PlainConfig(self.gain * 2, self.goal)


@pytest.mark.parametrize("config", [_PlainConfig(3.0), _CopyHookConfig(3.0)])
def test_snapshot_is_copy_copy_with_its_arrays_copied(config):
    copied, expected = snapshot(config), copy.copy(config)
    assert type(copied) is type(expected) and copied is not config
    for field in dataclasses.fields(config):
        got, want = getattr(copied, field.name), getattr(expected, field.name)
        assert np.array_equal(got, want)
        if isinstance(want, np.ndarray):
            # later edits of the original cannot reach it
            assert got is not getattr(config, field.name)
