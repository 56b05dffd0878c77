"""TOML config files: registration by import path, overrides, and one clear message per kind of
mistake."""

import textwrap

import pytest

import judo
from judo.core.configuration.registry import make_config
from judo.optimizers.mppi import MPPIConfig

USER_MODULE = '''
from dataclasses import dataclass
import numpy as np
import judo
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig

MODEL = __import__("pathlib").Path(__file__).with_name("tiny.xml")

@dataclass
class MyTaskConfig(judo.TaskConfig):
    weight: float = 1.0
    """A weight."""

class MyTask(judo.Task[MyTaskConfig]):
    def __init__(self):
        super().__init__(MODEL)

    def reward(self, states, sensors, controls, config, system_metadata=None):
        return -config.weight * np.square(states[..., 1]).sum(-1)

@dataclass
class MyOptConfig(PredictiveSamplingConfig):
    param: int = 1
    """A parameter."""

class MyOpt(PredictiveSampling):
    pass

NotATask = int
'''


@pytest.fixture
def user_dir(tmp_path, tiny_model_path):
    module = f"user_mod_{tmp_path.name.replace('-', '_')}"
    (tmp_path / f"{module}.py").write_text(USER_MODULE)
    (tmp_path / "tiny.xml").write_text(tiny_model_path.read_text())
    return tmp_path, module


def write(directory, text):
    path = directory / "judo.toml"
    path.write_text(textwrap.dedent(text))
    return path


def test_a_full_file_registers_and_overrides(user_dir):
    directory, module = user_dir
    path = write(
        directory,
        f'''
        task = "file_task"
        optimizer = "file_opt"
        [custom_tasks.file_task]
        task = "{module}.MyTask"
        config = "{module}.MyTaskConfig"
        [custom_optimizers.file_opt]
        optimizer = "{module}.MyOpt"
        config = "{module}.MyOptConfig"
        [controller_config_overrides.file_task]
        horizon = 0.5
        [optimizer_config_overrides.cylinder_push.file_opt]
        param = 42
        [optimizer_config_overrides.file_task.mppi]
        sigma = 0.9
        [task_config_overrides.file_task]
        weight = 4
        ''',
    )
    loaded = judo.load_config(path)
    assert (loaded.task, loaded.optimizer) == ("file_task", "file_opt")
    opt_config_cls = judo.get_registered_optimizers()["file_opt"][1]
    assert make_config(opt_config_cls, "cylinder_push").param == 42
    assert make_config(opt_config_cls, "cartpole").param == 1
    assert make_config(MPPIConfig, "file_task").sigma == 0.9
    controller = judo.make_controller("file_task", "file_opt", num_workers=1)
    assert controller.config.horizon == 0.5 and controller.task.config.weight == 4.0
    controller.close()


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            'tsk = "cartpole"',
            r"unknown top-level key 'tsk'; valid "
            r"keys are: task, optimizer, custom_tasks",
        ),
        ("task = [", r"TOML syntax error: .*line 1"),
        ('task = "cartpole"\noptimizer = = "ps"', r"TOML syntax error: .*at line 2, column"),
        (
            '[custom_tasks.x]\ntask = "nowhere_module.T"\nconfig = "nowhere_module.C"',
            r"\[custom_tasks.x\]: cannot import module 'nowhere_module' \(named by "
            r"task = \"nowhere_module.T\"\)",
        ),
        (
            '[custom_tasks.x]\ntask = "{module}.Missing"\nconfig = "{module}.MyTaskConfig"',
            r"module '{module}' has no attribute 'Missing' \(named by task = "
            r"\"{module}.Missing\"\)",
        ),
        (
            '[custom_tasks.x]\ntask = "{module}.NotATask"\nconfig = "{module}.MyTaskConfig"',
            r"task 'x' must be a subclass of Task, got <class 'int'>",
        ),
        (
            "[controller_config_overrides.cartpole]\nhorizn = 1.0",
            r"\[controller_config_overrides.cartpole\]: unknown field of "
            r"ControllerConfig 'horizn'; .*horizon",
        ),
        (
            '[controller_config_overrides.cartpole]\nhorizon = "long"',
            r"ControllerConfig.horizon expects a number, got 'long'",
        ),
        (
            "[optimizer_config_overrides.cartpole.mpi]\nsigma = 1.0",
            r"unknown optimizer 'mpi'; valid optimizers are: .*mppi",
        ),
        ('task = "cartpol"', r"\[task\]: unknown task 'cartpol'; valid tasks are: .*cartpole"),
    ],
)
def test_mistakes_name_the_offender(user_dir, body, message):
    directory, module = user_dir
    path = write(directory, body.replace("{module}", module))
    with pytest.raises(judo.ConfigFileError, match=message.replace("{module}", module)):
        judo.load_config(path)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(judo.ConfigFileError, match="config file not found: .*nope.toml"):
        judo.load_config(tmp_path / "nope.toml")


def test_the_all_section_sets_every_optimizers_base_fields_and_a_named_one_wins(tmp_path):
    path = write(
        tmp_path,
        """
        [custom_tasks.all_section_task]
        task = "judo.tasks.cartpole.Cartpole"
        config = "judo.tasks.cartpole.CartpoleConfig"
        [optimizer_config_overrides.all_section_task.all]
        num_rollouts = 48
        [optimizer_config_overrides.all_section_task.mppi]
        num_rollouts = 40
        """,
    )
    judo.load_config(path)
    from judo.optimizers.cem import CEMConfig

    assert make_config(CEMConfig, "all_section_task").num_rollouts == 48
    assert make_config(MPPIConfig, "all_section_task").num_rollouts == 40


def test_an_unknown_optimizer_section_lists_all_among_the_valid_names(tmp_path):
    path = write(tmp_path, "[optimizer_config_overrides.pendulum.mpi]\nsigma = 0.1\n")
    with pytest.raises(
        judo.ConfigFileError,
        match=r"unknown optimizer 'mpi'; valid "
        r"optimizers are: all, cbo, cem",
    ):
        judo.load_config(path)


def test_a_per_optimizer_controller_section_applies_after_the_task_wide_one_and_to_that_optimizer_only(  # noqa: E501
    tmp_path,
):
    # overrides need a task
    judo.register_task("per_optimizer_task", *judo.get_registered_tasks()["cartpole"])
    path = write(
        tmp_path,
        """
        [controller_config_overrides.per_optimizer_task]
        horizon = 1.2
        control_freq = 40.0
        [controller_config_overrides.per_optimizer_task.ps]
        horizon = 0.8
        """,
    )
    judo.load_config(path)
    ps = make_config(judo.ControllerConfig, "per_optimizer_task", "ps")
    cem = make_config(judo.ControllerConfig, "per_optimizer_task", "cem")
    assert (ps.horizon, ps.control_freq) == (0.8, 40.0)  # its own horizon, the task-wide rate
    assert (cem.horizon, cem.control_freq) == (1.2, 40.0)
    assert make_config(judo.ControllerConfig, "per_optimizer_task").horizon == 1.2
    judo.load_config(write(tmp_path, "[controller_config_overrides.cartpole.ps]\nhorizon = 0.9\n"))
    with judo.make_controller("cartpole", "ps", num_workers=1) as ps_controller:
        assert ps_controller.config.horizon == 0.9
    with judo.make_controller("cartpole", "cem", num_workers=1) as cem_controller:
        assert (
            cem_controller.config.horizon
            == make_config(judo.ControllerConfig, "cartpole").horizon
            != 0.9
        )


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            "[controller_config_overrides.cartpole.mpi]\nhorizon = 1.0",
            r"\[controller_config_overrides.cartpole.mpi\]: unknown optimizer 'mpi'; "
            r"valid optimizers are: .*mppi",
        ),
        (
            "[controller_config_overrides.cartpole.ps]\nhorizn = 1.0",
            r"\[controller_config_overrides.cartpole.ps\]: unknown field of "
            r"ControllerConfig 'horizn'; .*horizon",
        ),
    ],
)
def test_a_bad_per_optimizer_controller_section_is_named(tmp_path, body, message):
    with pytest.raises(judo.ConfigFileError, match=message):
        judo.load_config(write(tmp_path, body))
