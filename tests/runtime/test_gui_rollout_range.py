"""The GUI's num_rollouts slider follows the rollout backend: thousands of rollouts on warp."""

import pytest
import viser

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.fields import SliderRange
from judo.core.rollouts.backend import ROLLOUT_BACKENDS
from judo.optimizers.mppi import MPPIConfig
from judo.runtime.app import App
from judo.runtime.gui.config_panel import ConfigPanel
from judo.runtime.gui.session_panels import MAX_ROLLOUTS_BY_BACKEND


def test_a_panel_range_replaces_the_config_classes_slider_range():
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        config = MPPIConfig(num_rollouts=32)
        own = ConfigPanel(server.gui, "own", config, lambda updates: config, order=1)
        wide = ConfigPanel(
            server.gui,
            "wide",
            config,
            lambda updates: config,
            order=2,
            ranges={"num_rollouts": SliderRange(1, 8192, 1)},
        )
        own_slider, wide_slider = own.handles("num_rollouts")[0], wide.handles("num_rollouts")[0]
        assert (own_slider.min, own_slider.max) == (1, 512)
        assert (wide_slider.min, wide_slider.max, wide_slider.step, wide_slider.value) == (
            1,
            8192,
            1,
            32,
        )
        # other fields keep theirs
        assert wide.handles("num_nodes")[0].max == own.handles("num_nodes")[0].max
    finally:
        server.stop()


def test_the_gui_widens_the_rollouts_slider_by_backend_name_only_for_warp():
    assert MAX_ROLLOUTS_BY_BACKEND == {"warp": 8192}  # "cpu" keeps the optimizer config's own range
    assert set(MAX_ROLLOUTS_BY_BACKEND) <= set(ROLLOUT_BACKENDS)  # keyed by names the factory knows


@pytest.mark.warp
def test_the_rollouts_slider_reaches_8192_on_the_warp_backend(port, wait_until):
    pytest.importorskip("warp")
    pytest.importorskip("mujoco_warp")
    # warp's CPU device launches each step's kernels one by one: keep T small
    short = ControllerConfig(horizon=0.2)
    app = App(
        "cartpole",
        "mppi",
        controller_config=short,
        host="127.0.0.1",
        port=port,
        seed=0,
        backend="warp",
    )
    app.start()
    try:
        wait_until(
            lambda: app.gui.shown_generation == app.session.generation,
            timeout=60,
            what="the GUI to build",
        )
        slider = app.gui.panels["optimizer"].handles("num_rollouts")[0]
        assert (slider.min, slider.max) == (1, 8192)
        assert app.session.controller.backend_name == "warp"
    finally:
        app.stop()
