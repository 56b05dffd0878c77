"""Model parameters as configuration: [model_overrides.TASK] and [plant_overrides.TASK] set MjModel
fields by element name on the planning model or the plant alone, and say in one line what they
expected."""

import textwrap

import numpy as np
import pytest

import judo
from judo.core.configuration.config_file import load_config
from judo.core.configuration.config_file_text import ConfigFileError
from judo.core.configuration.model_override_checks import check_model_overrides
from judo.core.configuration.model_overrides import overridden, parse_override_entries
from judo.core.configuration.registry import make_controller, make_task, set_model_overrides


def write(tmp_path, text):
    path = tmp_path / "fitted.toml"
    path.write_text(textwrap.dedent(text))
    return path


def test_model_overrides_change_the_planning_model_and_nothing_else(tmp_path):
    load_config(
        write(
            tmp_path,
            """
            [model_overrides.cartpole]
            body_mass.pole = 0.13
            dof_damping.slider = 0.05
            actuator_gear.push = 9.1
            """,
        )
    )
    with make_controller("cartpole", "mppi", num_workers=1) as controller:
        task = controller.task
        assert task.model.body_mass[task.model.body("pole").id] == 0.13
        assert task.model.dof_damping[task.model.joint("slider").dofadr[0]] == 0.05
        np.testing.assert_array_equal(task.model.actuator_gear[0], [9.1, 0, 0, 0, 0, 0])
        plant = judo.MujocoSystem.from_task(task, seed=0).task
    mjcf = judo.tasks.cartpole.Cartpole().model
    for model in (plant.sim_model, plant.model):  # the plant keeps the MJCF's parameters
        np.testing.assert_array_equal(model.body_mass, mjcf.body_mass)
        np.testing.assert_array_equal(model.dof_damping, mjcf.dof_damping)
        np.testing.assert_array_equal(model.actuator_gear, mjcf.actuator_gear)
    assert plant.model_overrides == {} and task.model_overrides["body_mass"]["pole"] == 0.13


def test_plant_overrides_change_the_plant_alone_and_every_plant_built_from_the_task(tmp_path):
    load_config(
        write(
            tmp_path,
            """
            [plant_overrides.cartpole]
            geom_friction.cart = [0.9, 0.005, 0.0001]
            body_mass.pole = 0.13
            """,
        )
    )
    with make_controller("cartpole", "mppi", num_workers=1) as controller:
        assert (
            controller.task.model.body_mass[2] == judo.tasks.cartpole.Cartpole().model.body_mass[2]
        )
        plant = judo.MujocoSystem.from_task(controller.task, seed=0).task
    cart = plant.sim_model.geom("cart").id
    np.testing.assert_allclose(plant.sim_model.geom_friction[cart], [0.9, 0.005, 0.0001])
    assert plant.sim_model.body_mass[plant.sim_model.body("pole").id] == 0.13
    assert plant.model.body_mass[2] != 0.13  # the plant task's own planning model is the MJCF's


def test_the_overrides_round_trip_through_a_written_file(tmp_path):
    """What sysid writes (the --config format) reads back to the same values."""
    set_model_overrides(
        "cartpole", {"body_mass": {"pole": 0.123456789}, "dof_damping": {"hinge": 0.02}}
    )
    written = write(
        tmp_path,
        """
        [model_overrides.cartpole]
        body_mass.pole = 0.123456789
        dof_damping.hinge = 0.02
        """,
    )
    before = make_task("cartpole").model
    load_config(written)
    after = make_task("cartpole").model
    np.testing.assert_array_equal(before.body_mass, after.body_mass)
    np.testing.assert_array_equal(before.dof_damping, after.dof_damping)


@pytest.mark.parametrize(
    "body, message",
    [
        (
            "body_mas.pole = 1.0",
            "unknown model field 'body_mas'; valid model fields are: body_gravcomp, body_inertia,",
        ),
        (
            "body_mass.pol = 1.0",
            "body_mass.pol: the model has no body 'pol'; its body names are: cart, pole, world",
        ),
        (
            "geom_friction.cart = [1, 2, 3, 4]",
            "geom_friction.cart must be a finite number or a list of at most 3",
        ),
        (
            "body_mass = 1.0",
            "body_mass needs an element name, as body_mass.NAME = value; got body_mass = 1.0",
        ),
        (
            'body_mass.pole = "heavy"',
            "body_mass.pole must be a number or a list of at most 1 numbers, got 'heavy'",
        ),
        ("qpos0.cart = 1.0", "unknown model field 'qpos0'; valid model fields are: actuator_acc0,"),
    ],
)
def test_mistakes_are_one_line_naming_the_valid_choices(tmp_path, body, message):
    path = write(tmp_path, f"[model_overrides.cartpole]\n{body}\n")
    with pytest.raises(ConfigFileError) as caught:
        load_config(path)
    text = str(caught.value)
    assert (
        "\n" not in text
        and text.startswith(f"{path}: [model_overrides.cartpole]: ")
        and message in text
    )


def test_an_unknown_task_section_lists_the_tasks(tmp_path):
    with pytest.raises(
        ConfigFileError,
        match=r"\[plant_overrides.cartpol\]: "
        r"unknown task 'cartpol'; valid tasks",
    ):
        load_config(write(tmp_path, "[plant_overrides.cartpol]\nbody_mass.pole = 1.0\n"))


def test_a_dof_field_sets_every_dof_of_a_free_joint():
    model = make_task("leap_cube").model
    checked = check_model_overrides(model, {"dof_damping": {"cube": [1, 2, 3, 4, 5, 6]}})
    new = overridden(model, checked)
    start = model.joint("cube").dofadr[0]
    np.testing.assert_array_equal(new.dof_damping[start : start + 6], [1, 2, 3, 4, 5, 6])
    assert not np.array_equal(model.dof_damping, new.dof_damping)  # the original is never changed


def test_command_line_entries_parse_numbers_and_lists():
    entries = ["body_mass.pole=0.13", "geom_friction.cube=[0.9, 0.005, 0.0001]"]
    assert parse_override_entries(entries) == {
        "body_mass": {"pole": 0.13},
        "geom_friction": {"cube": [0.9, 0.005, 0.0001]},
    }
    with pytest.raises(
        judo.ConfigError,
        match=r"--plant-overrides takes "
        r"FIELD.ELEMENT=VALUE entries .*got 'pole=1'",
    ):
        parse_override_entries(["pole=1"])


def test_an_option_override_is_leap_cube_plant_xml_bit_for_bit():
    """opt.o_friction turns on MuJoCo's contact override as leap_cube_plant.xml's <flag
    override="enable"/> does."""
    import mujoco

    from judo.tasks.leap_cube import PLANT_MODEL_PATH, LeapCube

    xml = LeapCube(sim_model_path=PLANT_MODEL_PATH).sim_model
    planning = LeapCube().model
    entries = ["opt.o_friction=[0.9, 0.9, 0.02, 0.0001, 0.0001]"]
    model = overridden(planning, check_model_overrides(planning, parse_override_entries(entries)))
    finals = []
    for each in (xml, model, planning):
        data = mujoco.MjData(each)
        mujoco.mj_resetDataKeyframe(each, data, 0)
        for step in range(100):
            data.ctrl[:] = 0.3 * np.sin(0.1 * step + np.arange(each.nu))
            mujoco.mj_step(each, data)
        finals.append(np.concatenate([data.qpos, data.qvel]))
    np.testing.assert_array_equal(finals[0], finals[1])
    assert not np.array_equal(finals[0], finals[2])
    with pytest.raises(
        judo.UnknownNameError,
        match=r"^opt.o_frict: MjOption has no "
        r"float field 'o_frict'; its fields",
    ):
        check_model_overrides(planning, {"opt": {"o_frict": 1.0}})


def test_a_backend_shared_by_episodes_plans_on_the_config_files_fitted_model(tmp_path):
    from judo.evaluation.seeded import EpisodeSpec, planning_model

    config = tmp_path / "fitted.toml"
    config.write_text("[model_overrides.cartpole]\nbody_mass.pole = 0.5\n")
    model = planning_model(EpisodeSpec("cartpole", "ps", 1.0, config_file=str(config)))
    # the file was read before the model was built
    assert model.body_mass[model.body("pole").id] == 0.5


@pytest.mark.parametrize(
    "entry, message",
    [
        ("opt.timestep=0", "opt.timestep must be above 0 for MuJoCo to simulate it, got 0"),
        ("opt.timestep=-0.01", "opt.timestep must be above 0 for MuJoCo to simulate it, got -0.01"),
        (
            "body_mass.pole=-1",
            "body_mass.pole must be at least 0 for MuJoCo to simulate it, got -1",
        ),
        (
            "body_mass.pole=0",
            "body 'pole' moves, so MuJoCo's compiler requires its mass and inertia "
            "at least mjMINVAL = 1e-15; "
            "got body_mass.pole = 0, body_inertia.pole = [0.00369089, 0.00369089, 9.94091e-05]",
        ),
        (
            "body_mass.cart=1e300",
            "body_mass.cart must be within ±1e+10 (mjMAXVAL: MuJoCo takes a "
            "magnitude beyond it as diverged), got 1e+300",
        ),
        (
            "body_inertia.pole=[1, 1, 3]",
            "body_inertia.pole must be principal inertias of which any two add up to "
            "at least the third (A + B >= C), "
            "as MuJoCo's compiler requires, got [1, 1, 3]",
        ),
        (
            "geom_size.cart=[0, 0.1, 0.1]",
            "geom_size.cart must have size[0], size[1], size[2] above 0 for a box "
            "geom, as MuJoCo's compiler "
            "requires, got [0, 0.1, 0.1]",
        ),
        (
            "jnt_range.slider=[1, -1]",
            "jnt_range.slider must have its lower end below its upper, as MuJoCo's "
            "compiler requires for a limited "
            "joint, got [1, -1]",
        ),
        (
            "dof_damping.slider=-1",
            "dof_damping.slider must be at least 0 for MuJoCo to simulate it, got -1",
        ),
        (
            # no rule of judo's: MuJoCo's own mass matrix turns singular
            "jnt_axis.hinge=[0, 0, 0]",
            "jnt_axis.hinge = [0, 0, 0]: MuJoCo cannot simulate the model this "
            "makes: Inertia matrix is too close to "
            "singular, or the effective-metric solve failed to converge, at DOF 1 "
            "(in 10 steps from qpos0, where the "
            "model without it runs clean)",
        ),
    ],
)
def test_a_model_mujoco_cannot_simulate_is_refused_in_one_line(entry, message, capfd):
    model = make_task("cartpole").sim_model
    with pytest.raises(judo.ConfigError) as caught:
        check_model_overrides(model, parse_override_entries([entry]))
    assert str(caught.value) == message
    assert capfd.readouterr() == ("", "")  # MuJoCo's own warning lines are counted, never printed


def test_a_config_files_absurd_mass_is_refused_and_overrides_are_checked_with_the_earlier_ones(
    tmp_path,
):
    path = write(tmp_path, "[model_overrides.cartpole]\nbody_mass.pole = -1\n")
    with pytest.raises(ConfigFileError) as caught:
        load_config(path)
    expected = (
        f"{path}: [model_overrides.cartpole]: body_mass.pole must be at least 0 for MuJoCo to "
        "simulate it"
    )
    assert str(caught.value) == f"{expected}, got -1"
    set_model_overrides("cartpole", {"jnt_axis": {"hinge": [0.0, 1.0, 0.0]}}, plant=True)
    with pytest.raises(
        judo.ConfigError,
        match=r"^jnt_axis.hinge = \[0, 1, 0\], "
        r"jnt_axis.slider = \[0, 0, 0\]: MuJoCo",
    ):
        set_model_overrides("cartpole", {"jnt_axis": {"slider": [0.0, 0.0, 0.0]}}, plant=True)
    # the refused entry was never set
    assert make_task("cartpole").sim_model.jnt_axis[0].tolist() == [1, 0, 0]


@pytest.mark.slow
def test_a_sensible_override_of_every_task_passes():
    """No task's model warns in MuJoCo's steps: a heavier first moving body and more damping are
    simulable."""
    for name in judo.get_registered_tasks():
        model = make_task(name).sim_model
        body = next(b for b in range(1, model.nbody) if model.body_jntnum[b] and model.body(b).name)
        overrides = {"body_mass": {model.body(body).name: 1.1 * model.body_mass[body]}}
        overrides["dof_damping"] = {model.joint(0).name: 0.1}
        assert set(check_model_overrides(model, overrides)) == {"body_mass", "dof_damping"}, name


@pytest.mark.parametrize(
    "section, message",
    [
        ('fitted = ["body_mass.cart"]', "fitted names 'body_mass.cart', which "
                                        "[model_overrides.cartpole] does not "
                                        "set; "
         "it sets: body_mass.pole"),
        ("fitted = 1", 'fitted must be a list of "FIELD.ELEMENT" strings, got 1'),
        ('fit = ["body_mass.pole"]', "must hold only fitted = "
                                     "[\"FIELD.ELEMENT\", ...], got {'fit': "
                                     "['body_mass.pole']}"),
    ],
)  # fmt: skip
def test_a_sysid_section_names_only_the_entries_its_file_sets(tmp_path, section, message):
    path = write(
        tmp_path,
        f"[model_overrides.cartpole]\nbody_mass.pole = 0.13\n[sysid.cartpole]\n{section}\n",
    )
    with pytest.raises(ConfigFileError) as caught:
        load_config(path)
    assert str(caught.value).startswith(f"{path}: [sysid.cartpole]") and str(caught.value).endswith(
        message
    )
