"""Registration, per-task overrides, and the error messages a user sees at the boundary."""

from dataclasses import dataclass

import numpy as np
import pytest

import judo
from judo.core.configuration.registry import make_config
from judo.optimizers.cem import CEMConfig
from judo.optimizers.mppi import MPPIConfig


def test_builtins_are_registered_by_name():
    assert {"cartpole", "cylinder_push"} <= set(judo.get_registered_tasks())
    assert {"ps", "cem", "mppi"} <= set(judo.get_registered_optimizers())
    assert judo.get_registered_optimizers()["mppi"][1] is MPPIConfig


def test_unknown_names_list_the_valid_ones():
    with pytest.raises(
        judo.UnknownNameError,
        match=r"unknown task 'cartpol'; valid tasks "
        r"are: .*cartpole, .*cylinder_push",
    ):
        judo.make_controller("cartpol", "mppi")
    with pytest.raises(
        judo.UnknownNameError,
        match=r"unknown optimizer 'mpi'; valid "
        r"optimizers are: .*cem, .*mppi, .*ps",
    ):
        judo.make_controller("cartpole", "mpi")


def test_register_a_user_task_and_override_its_configs(tiny_model_path):
    @dataclass
    class MyConfig(judo.TaskConfig):
        weight: float = 1.0
        """A weight."""

    class MyTask(judo.Task[MyConfig]):
        def __init__(self):
            super().__init__(tiny_model_path)

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return -config.weight * np.square(states[..., 1]).sum(-1)

    judo.register_task("my_task", MyTask, MyConfig)
    judo.set_config_overrides("my_task", judo.ControllerConfig, {"horizon": 0.5})
    judo.set_config_overrides("my_task", judo.OptimizerConfig, {"num_rollouts": 12})
    judo.set_config_overrides("my_task", MPPIConfig, {"sigma": 0.7})
    judo.set_config_overrides("my_task", MyConfig, {"weight": 3})
    controller = judo.make_controller("my_task", "mppi", num_workers=1)
    assert controller.config.horizon == 0.5
    assert (
        controller.optimizer.config.num_rollouts == 12 and controller.optimizer.config.sigma == 0.7
    )
    assert controller.task.config.weight == 3.0 and isinstance(controller.task.config.weight, float)
    # the base-class override reaches every optimizer
    assert make_config(CEMConfig, "my_task").num_rollouts == 12
    # other tasks keep their own (cartpole.toml)
    assert make_config(MPPIConfig, "cartpole").num_rollouts == 64
    controller.update_action(np.zeros(4), 0.0)
    assert controller.rewards.shape == (12,)
    controller.close()


def test_overrides_are_checked_when_set():
    with pytest.raises(
        judo.UnknownNameError,
        match=r"unknown field of MPPIConfig 'sigmaa'; "
        r"valid field of MPPIConfigs are: .*sigma",
    ):
        judo.set_config_overrides("cartpole", MPPIConfig, {"sigmaa": 1.0})
    with pytest.raises(judo.ConfigError, match="MPPIConfig.sigma expects a number, got 'big'"):
        judo.set_config_overrides("cartpole", MPPIConfig, {"sigma": "big"})
    with pytest.raises(
        judo.ConfigError,
        match=r"ControllerConfig.spline_order expects one of \['zero', 'linear', 'cubic'\], got "
        r"'quadratic'",
    ):
        judo.set_config_overrides("cartpole", judo.ControllerConfig, {"spline_order": "quadratic"})


def test_registering_a_non_task_is_refused():
    with pytest.raises(
        judo.JudoError, match="task 'bad' must be a subclass of Task, got <class 'int'>"
    ):
        judo.register_task("bad", int, judo.TaskConfig)  # type: ignore[arg-type]


def test_invalid_configs_fail_at_construction(upright_task):
    with pytest.raises(judo.ConfigError, match="num_rollouts must be between 1 and 1048576, got 0"):
        judo.OptimizerConfig(num_rollouts=0)
    with pytest.raises(judo.ConfigError, match="num_elites must be between 1 and num_rollouts"):
        CEMConfig(num_rollouts=4, num_elites=8)
    from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig

    optimizer = PredictiveSampling(PredictiveSamplingConfig(num_nodes=3), upright_task.nu)
    with pytest.raises(
        judo.ConfigError,
        match=r"horizon \(0.005 s\) is shorter "
        r"than one timestep \(0.01 s\)",
    ):
        judo.Controller(judo.ControllerConfig(horizon=0.005), upright_task, optimizer)
    with pytest.raises(judo.ConfigError, match="a cubic spline needs num_nodes >= 4, got 3"):
        judo.Controller(judo.ControllerConfig(spline_order="cubic"), upright_task, optimizer)


def test_an_invalid_live_edit_raises_at_the_next_cycle(upright_task):
    from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig

    controller = judo.Controller(
        judo.ControllerConfig(),
        upright_task,
        PredictiveSampling(PredictiveSamplingConfig(), 1),
        num_workers=1,
    )
    controller.update_action(np.zeros(4), 0.0)
    controller.optimizer.config.num_rollouts = 0
    with pytest.raises(judo.ConfigError, match="num_rollouts must be between 1 and 1048576, got 0"):
        controller.update_action(np.zeros(4), 0.02)


def test_bad_model_paths_are_named(tmp_path):
    from tests.conftest import UprightTask

    with pytest.raises(judo.ModelLoadError, match="MuJoCo model file not found: .*missing.xml"):
        UprightTask(tmp_path / "missing.xml")
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><geom type='box'/></worldbody>")
    with pytest.raises(judo.ModelLoadError, match="could not compile MuJoCo model .*broken.xml"):
        UprightTask(broken)


def test_task_helpers_read_without_mutating_the_model(upright_task):
    before = upright_task.model.actuator_ctrlrange.copy()
    np.testing.assert_array_equal(upright_task.actuator_ctrlrange, [[-1.0, 1.0]])
    np.testing.assert_array_equal(upright_task.model.actuator_ctrlrange, before)
    assert upright_task.nu == 1 and upright_task.dt == 0.01
    assert upright_task.get_sensor_start_index("angle") == 3
    assert upright_task.get_joint_position_start_index("hinge") == 1
    assert upright_task.get_joint_velocity_start_index("hinge") == 3
    with pytest.raises(
        judo.UnknownNameError, match="unknown joint 'elbow'; valid joints are: hinge, slider"
    ):
        upright_task.get_joint_position_start_index("elbow")


def test_slider_and_np_1d_field_attach_metadata_only():
    from judo.core.configuration.fields import array_field_spec, slider_ranges

    @judo.slider("gain", 0.0, 10.0, 0.5)
    @dataclass
    class Cfg(judo.TaskConfig):
        gain: float = 1.0
        """A gain."""
        goal: np.ndarray = judo.np_1d_field(np.array([1.0, 2.0]), names=["x", "y"], vis_name="goal")
        """A goal."""

    a, b = Cfg(), Cfg()
    a.goal[0] = 5.0
    assert b.goal[0] == 1.0  # each instance owns its array
    assert slider_ranges(Cfg)["gain"].step == 0.5
    spec = array_field_spec(Cfg, "goal")
    assert spec is not None and spec.names == ("x", "y") and spec.vis_name == "goal"
    with pytest.raises(judo.ConfigError, match="np_1d_field: names has 1 entries, the array has 2"):
        judo.np_1d_field(np.array([1.0, 2.0]), names=["x"])


def test_a_subclass_of_a_task_keeps_or_names_its_config_class(tiny_model_path):
    @dataclass
    class BaseConfig(judo.TaskConfig):
        weight: float = 1.0
        """A weight."""

    @dataclass
    class ChildConfig(BaseConfig):
        extra: float = 2.0
        """Another weight."""

    class BaseTask(judo.Task[BaseConfig]):
        def __init__(self):
            super().__init__(tiny_model_path)

        def reward(self, states, sensors, controls, config, system_metadata=None):
            return np.zeros(states.shape[0])

    class SameConfigTask(BaseTask):
        pass

    class OwnConfigTask(BaseTask):
        config_cls = ChildConfig

    assert type(SameConfigTask().config) is BaseConfig
    assert type(OwnConfigTask().config) is ChildConfig
    assert type(BaseTask().config) is BaseConfig
