"""Shared fixtures: a tiny inline cart-pole model and task, so core tests need no shipped model."""

from dataclasses import dataclass

import numpy as np
import pytest

import judo

TINY_CARTPOLE_XML = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="cart">
      <joint name="slider" type="slide" axis="1 0 0"/>
      <geom type="box" size=".2 .1 .1" mass="1"/>
      <body name="pole">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.6" size=".04" mass=".1"/>
        <site name="tip" pos="0 0 0.6"/>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="slider" gear="10" ctrlrange="-1 1" ctrllimited="true"/></actuator>
  <sensor>
    <framepos name="trace_tip" objtype="site" objname="tip"/>
    <jointpos name="angle" joint="hinge"/>
  </sensor>
</mujoco>
"""


@pytest.fixture
def tiny_model_path(tmp_path):
    path = tmp_path / "tiny_cartpole.xml"
    path.write_text(TINY_CARTPOLE_XML)
    return path


@dataclass
class UprightConfig(judo.TaskConfig):
    """Weights of the tiny upright task."""

    w_upright: float = 1.0
    """Weight on the pole staying upright."""


class UprightTask(judo.Task[UprightConfig]):
    """Keep the tiny cart-pole's pole upright (angle 0) with little control."""

    def reward(self, states, sensors, controls, config, system_metadata=None):
        return -config.w_upright * (1.0 - np.cos(states[..., 1])).sum(-1) - 0.01 * np.square(
            controls
        ).sum((-1, -2))


@pytest.fixture
def upright_task(tiny_model_path):
    return UprightTask(tiny_model_path)


@pytest.fixture(autouse=True)
def restore_the_registry():
    """Each test starts from the registry `import judo` builds: a doc snippet or config file that
    registers a task or sets overrides (on cartpole, say) must not change what later tests see."""
    from judo.core.configuration import registry

    tasks, optimizers = dict(registry._TASKS), dict(registry._OPTIMIZERS)
    overrides = {key: dict(value) for key, value in registry._OVERRIDES.items()}
    model_overrides = {key: dict(value) for key, value in registry._MODEL_OVERRIDES.items()}
    fitted = {key: set(value) for key, value in registry._FITTED.items()}
    yield
    for table, saved in (
        (registry._TASKS, tasks),
        (registry._OPTIMIZERS, optimizers),
        (registry._OVERRIDES, overrides),
        (registry._MODEL_OVERRIDES, model_overrides),
        (registry._FITTED, fitted),
    ):
        table.clear()
        table.update(saved)


@pytest.fixture(autouse=True)
def stop_file_of_the_test(tmp_path_factory, monkeypatch):
    """Every app a test runs (in-process or a subprocess) keeps its latched stop in a file of the
    test's own (judo.safety.stop), never the user's: a stop latched by hand does not stop the suite,
    nor a test's the user."""
    monkeypatch.setenv("JUDO_STOP_FILE", str(tmp_path_factory.mktemp("stop") / "stop.json"))


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray with 2 CPUs for the module, started by the call collect, evaluate --workers and
    tune make (`start_ray`: on 127.0.0.1). Ray is imported here, so the tests that do not use it
    never import it."""
    pytest.importorskip("ray")
    from judo.ray_cluster import start_ray, stop_ray

    start_ray(None, 2)
    yield
    stop_ray()
