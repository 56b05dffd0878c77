"""The app with model and plant overrides: it plans on the overridden model, simulates the plant's
own, says so on its status line (a fitted model only where sysid fitted it), and Reset configs keeps
both."""

import textwrap

import pytest

from judo.core.configuration.config_file import load_config
from judo.core.configuration.registry import set_model_overrides
from judo.runtime.app import App
from judo.runtime.launch import _peek


def test_the_app_plans_on_the_fitted_model_simulates_the_plant_and_says_so(tmp_path):
    path = tmp_path / "fitted.toml"
    path.write_text(
        textwrap.dedent(
            """
            [model_overrides.cartpole]
            body_mass.pole = 0.13
            [plant_overrides.cartpole]
            dof_damping.slider = 0.005
            """
        )
    )
    load_config(path)
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    try:
        planning = app.controller.task.model
        plant = app.session.simulated.task.sim_model
        assert planning.body_mass[2] == 0.13 and plant.body_mass[2] == 0.1
        assert plant.dof_damping[0] == 0.005 and planning.dof_damping[0] == 0.001
        # by hand
        expected = "running cartpole with ps, planning with a model with overrides (body_mass.pole)"
        assert app._reports.running() == expected
        app.commands.reset_configs()
        assert app.controller.task.model.body_mass[2] == 0.13
    finally:
        app.stop()


def test_the_app_says_fitted_only_for_the_entries_sysid_fitted(tmp_path):
    path = tmp_path / "fitted.toml"
    path.write_text(
        textwrap.dedent(
            """
            [model_overrides.cartpole]
            body_mass.pole = 0.13
            dof_damping.slider = 0.05
            [sysid.cartpole]
            fitted = ["body_mass.pole", "dof_damping.slider"]
            """
        )
    )
    load_config(path)
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    try:
        expected = (
            "running cartpole with ps, planning with a fitted model (body_mass.pole, "
            "dof_damping.slider)"
        )
        assert app._reports.running() == expected
    finally:
        app.stop()
    # by hand, over the fitted value
    set_model_overrides("cartpole", {"dof_damping": {"slider": 0.07}})
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    try:
        expected = (
            "planning with a model with overrides (body_mass.pole fitted by sysid, "
            "dof_damping.slider)"
        )
        assert app._reports.running() == f"running cartpole with ps, {expected}"
    finally:
        app.stop()


def test_the_apps_plant_overrides_flag_sets_the_plant_and_names_a_mistake():
    assert _peek(["--task", "cartpole", "--plant-overrides", "body_mass.pole=0.2"])[:3] == (
        "cartpole",
        "mppi",
        None,
    )
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    try:
        assert app.session.simulated.task.sim_model.body_mass[2] == 0.2
        assert app.controller.task.model.body_mass[2] == 0.1
        assert app._reports.running() == "running cartpole with ps"
    finally:
        app.stop()
    with pytest.raises(
        Exception,
        match=r"^body_mass.pol: the model has "
        r"no body 'pol'; its body names are",
    ):
        _peek(["--task", "cartpole", "--plant-overrides", "body_mass.pol=0.2"])


@pytest.mark.slow
def test_sysid_fits_the_plant_from_a_gui_recording(tmp_path, wait_until, capsys):
    """A recording of the running app on a heavier-pole plant is a log sysid reads: the fit finds
    the pole."""
    pytest.importorskip("h5py")
    pytest.importorskip("scipy")
    from judo.sysid.sysid import main as sysid_main

    set_model_overrides("cartpole", {"body_mass": {"pole": 0.13}}, plant=True)
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    app.start()
    try:
        path = app.start_recording(tmp_path / "run.h5")
        wait_until(lambda: app.stats.num_plans() >= 30, what="thirty plans")
    finally:
        app.stop()  # writes the recording
    out = tmp_path / "fitted.toml"
    assert (
        sysid_main(
            [str(path), "--task", "cartpole", "--params", "body_mass.pole", "--out", str(out)]
        )
        == 0
    )
    assert float(out.read_text().split("body_mass.pole = ")[1].split()[0]) == pytest.approx(
        0.13, rel=0.05
    )
