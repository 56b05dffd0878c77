"""python -m judo sysid: real mujoco.sysid fits on a short collect of a mismatched plant, the fitted --config file,
and one-line errors (exit 2, nothing written) for the logs and arguments it cannot use."""  # noqa: E501

import re
import subprocess
import sys

import numpy as np
import pytest

from judo.collection.episode import collect_episode
from judo.core.configuration.config_file import load_config
from judo.core.configuration.registry import make_controller
from judo.evaluation.seeded import EpisodeSpec
from judo.loop.system import MujocoSystem
from judo.recording.dataset import DatasetFile
from judo.sysid.sysid import main as sysid_main

h5py = pytest.importorskip("h5py")
pytest.importorskip("scipy")
pytest.importorskip("colorama")

TRUE_MASS, TRUE_DAMPING = 0.13, 0.005
"""The plant's pole mass and slider damping: x1.3 and x5 the cartpole MJCF's 0.1 and 0.001."""


def write_log(path, task="cartpole", seconds=2.0):
    """A collect file of one cartpole x mppi episode of `seconds` on the mismatched plant (written
    as `task`)."""
    overrides = (f"body_mass.pole={TRUE_MASS}", f"dof_damping.slider={TRUE_DAMPING}")
    outcome = collect_episode(
        EpisodeSpec("cartpole", "mppi", seconds, plant_overrides=overrides), 0
    )
    assert outcome.failure is None
    DatasetFile(path, {"task": task, "optimizer": "mppi", "plant_timestep": 0.01}).write_episode(
        outcome.episode
    )
    return path


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    return write_log(tmp_path_factory.mktemp("sysid") / "cartpole.h5")


@pytest.mark.slow
def test_a_fit_finds_the_plants_mass_and_damping_and_the_file_changes_only_the_planning_model(
    log, tmp_path, capsys
):
    out = tmp_path / "fitted.toml"
    argv = [
        str(log),
        "--task",
        "cartpole",
        "--params",
        "body_mass.pole",
        "dof_damping.slider",
        "geom_friction.pole[0]",
    ]
    assert sysid_main([*argv, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert (
        "| geom_friction.pole[0] | 1 | 1 | unbounded | no: not excited by the data, left out of "
        "--out |"
    ) in printed
    assert "cond(J) = inf" in printed  # the unexcited friction makes the fit's Jacobian singular
    assert re.search(
        r"\| body_mass.pole \| 0.1 \| 0.1[23]\d* \| ± [\d.e-]+ \| yes \|",
        (tmp_path / "fitted.md").read_text(),
    )
    load_config(out)
    with make_controller("cartpole", "mppi", num_workers=1) as controller:
        model = controller.task.model
        assert model.body_mass[model.body("pole").id] == pytest.approx(TRUE_MASS, rel=0.05)
        assert model.dof_damping[model.joint("slider").dofadr[0]] == pytest.approx(
            TRUE_DAMPING, rel=0.05
        )
        np.testing.assert_array_equal(
            model.geom_friction[model.geom("pole").id], [1.0, 0.005, 0.0001]
        )
        plant = MujocoSystem.from_task(controller.task, seed=0).task.sim_model
    assert plant.body_mass[plant.body("pole").id] == 0.1  # the plant stays the MJCF's
    assert "geom_friction" not in out.read_text().split("[model_overrides.cartpole]")[1]


def corrupt(path):
    path.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(range(256)) * 4)
    return path


def without_actions(path, log):
    path.write_bytes(log.read_bytes())
    with h5py.File(path, "a") as file:
        del file["data/demo_0/actions"]
    return path


@pytest.mark.parametrize(
    "case, message",
    [
        ("another_task", "another.h5: a log of task 'acrobot', not of --task 'cartpole'"),
        (
            "no_actions",
            "no_actions.h5: episode demo_0 has no actions; sysid needs the actions "
            "served to the plant",
        ),
        ("unknown_field", "unknown model field 'body_mas'; valid model fields are: body_gravcomp,"),
        (
            "unknown_element",
            "body_mass.pol: the model has no body 'pol'; its body names are: cart, pole, world",
        ),
        ("unwritable_out", "is a file, so"),
        ("empty", "empty.h5: the file is empty"),
        ("corrupt", "corrupt.h5: not a readable HDF5 log"),
    ],
)
def test_mistakes_exit_2_in_one_line_and_write_nothing(log, tmp_path, capsys, case, message):
    logs = {
        "another_task": lambda: write_log(tmp_path / "another.h5", task="acrobot", seconds=0.2),
        "no_actions": lambda: without_actions(tmp_path / "no_actions.h5", log),
        "empty": lambda: (tmp_path / "empty.h5").touch() or tmp_path / "empty.h5",
        "corrupt": lambda: corrupt(tmp_path / "corrupt.h5"),
    }
    path = logs[case]() if case in logs else log
    params = {"unknown_field": "body_mas.pole", "unknown_element": "body_mass.pol"}.get(
        case, "body_mass.pole"
    )
    (tmp_path / "afile").write_text("")
    out = tmp_path / ("afile/fitted.toml" if case == "unwritable_out" else "out/fitted.toml")
    with pytest.raises(SystemExit) as caught:
        sysid_main([str(path), "--task", "cartpole", "--params", params, "--out", str(out)])
    assert caught.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and message in err
    assert not (tmp_path / "out").exists()


def test_import_judo_imports_no_sysid_dependency():
    code = (
        "import sys, judo, judo.sysid.sysid; print(sorted({'mujoco.sysid', 'scipy', 'colorama'} "
        "& set(sys.modules)))"
    )
    assert (
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout
        == "[]\n"
    )


@pytest.mark.slow
def test_a_user_task_with_a_heavier_plant_model_gets_its_pole_fitted_and_the_file_registers_it(
    tmp_path, capsys
):
    """examples/11_sysid: a custom task whose sim_model_path has a 0.3 kg pole; the fit (mass, and
    the inertia the heavier geom of the same shape brings, its row scaled as one) lands on it, and
    the written file registers the task beside its module and keeps the --config file's settings, so
    that it changes the planning model and nothing else."""
    import shutil
    from pathlib import Path

    from judo.core.configuration.registry import make_task

    folder = tmp_path / "robot"
    shutil.copytree(Path(__file__).resolve().parents[2] / "examples" / "11_sysid", folder)
    load_config(folder / "judo.toml")
    outcome = collect_episode(EpisodeSpec("heavy_cartpole", "mppi", 2.0), 0)
    assert outcome.failure is None
    log = folder / "run.h5"
    DatasetFile(log, {"task": "heavy_cartpole", "optimizer": "mppi"}).write_episode(outcome.episode)
    argv = [str(log), "--config", str(folder / "judo.toml"), "--task", "heavy_cartpole"]
    out = folder / "fitted.toml"
    assert (
        sysid_main([*argv, "--params", "body_mass.pole", "body_inertia.pole", "--out", str(out)])
        == 0
    )
    written = out.read_text()
    assert "[custom_tasks.heavy_cartpole]" in written
    assert (
        "[optimizer_config_overrides.heavy_cartpole.mppi]\nsigma = 0.3\ntemperature = 0.1"
        in written
    )
    assert load_config(out) is not None
    task = make_task("heavy_cartpole")
    assert task.model.body_mass[2] == pytest.approx(task.sim_model.body_mass[2], rel=0.05)
    assert task.sim_model.body_mass[2] == 0.3
    np.testing.assert_allclose(
        task.model.body_inertia[2], task.sim_model.body_inertia[2], rtol=0.05
    )


def test_excite_stays_within_the_actuator_limits_and_logs_what_sysid_fits(tmp_path, capsys):
    from judo.sysid.excite import main as excite_main

    log = tmp_path / "excite.h5"
    overrides = ["--plant-overrides", f"body_mass.pole={TRUE_MASS}"]
    assert (
        excite_main(
            [
                "--task",
                "cartpole",
                "--duration",
                "3",
                "--amplitude",
                "0.8",
                *overrides,
                "--out",
                str(log),
            ]
        )
        == 0
    )
    with h5py.File(log, "r") as file:
        actions = file["data/demo_0/actions"][:]
    assert (
        actions.shape == (300, 1)
        and np.abs(actions).max() <= 0.8 + 1e-12
        and np.abs(actions).max() > 0.7
    )
    out = tmp_path / "fitted.toml"
    assert (
        sysid_main(
            [str(log), "--task", "cartpole", "--params", "body_mass.pole", "--out", str(out)]
        )
        == 0
    )
    assert float(out.read_text().split("body_mass.pole = ")[1].split()[0]) == pytest.approx(
        TRUE_MASS, rel=0.01
    )
    with pytest.raises(SystemExit) as caught:
        excite_main(["--task", "cartpole", "--amplitude", "2", "--out", str(tmp_path / "never.h5")])
    assert caught.value.code == 2 and not (tmp_path / "never.h5").exists()
    assert "error: --amplitude must be in (0, 1], got 2.0" in capsys.readouterr().err


def test_fit_delay_finds_the_motor_lag_and_mass_of_examples_06_robot_driven_through_its_own_system(
    tmp_path, capsys
):
    """examples/06's robot (pole 10% heavier, each action reaching the motor 20 ms late), excited
    open loop through its `System` interface and logged in collect's layout: --fit-delay finds the
    lag beside the mass, and writes it as a comment (cartpole.xml keeps no actuator history for
    MuJoCo's actuator_delay)."""
    import importlib.util
    from pathlib import Path

    from judo.sysid.excite import excitation_episode, multisine

    path = Path(__file__).resolve().parents[2] / "examples" / "06_hardware_system.py"
    spec = importlib.util.spec_from_file_location("hardware_system", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    robot = example.LaggyNoisyCartpole(actuation_latency=0.02, noise_std=0.0, seed=0)
    controls = multisine(
        robot.model.actuator_ctrlrange, np.arange(300) * robot.timestep, 0.5, 2.0, 0
    )
    states = np.zeros((300, 4))
    for step, control in enumerate(controls):
        robot.apply(control)
        robot.step()
        # the stand-in's true state
        states[step] = np.concatenate([robot.data.qpos, robot.data.qvel])
    log = tmp_path / "robot.h5"
    episode = excitation_episode(
        0, robot.model, states, np.zeros((300, robot.model.nsensordata)), controls
    )
    DatasetFile(log, {"task": "cartpole", "plant_timestep": 0.01}).write_episode(episode)
    out = tmp_path / "fitted.toml"
    argv = [
        str(log),
        "--task",
        "cartpole",
        "--params",
        "body_mass.pole",
        "--fit-delay",
        "--out",
        str(out),
    ]
    assert sysid_main(argv) == 0
    report = (tmp_path / "fitted.md").read_text()
    delay = re.search(r"\| delay \(s\) \| 0 \| ([\d.e-]+) \| ± [\d.e-]+ \| yes \|", report)
    assert delay is not None and float(delay.group(1)) == pytest.approx(0.02, rel=0.05)
    mass = re.search(r"\| body_mass.pole \| 0.1 \| ([\d.e-]+) \|", report)
    assert float(mass.group(1)) == pytest.approx(0.11, rel=0.05)
    written = out.read_text()
    assert "actuator_delay" not in written.split("# fitted actuation delay")[0]
    assert (
        re.search(r"# fitted actuation delay: 0.0[12]\d* s\.", written) and 'nsample="3"' in written
    )
    load_config(out)
    with make_controller("cartpole", "mppi", num_workers=1) as controller:
        assert controller.task.model.body_mass[2] == pytest.approx(0.11, rel=0.05)


def test_the_fitted_file_is_the_config_given_with_the_fitted_values_in_its_model_overrides():
    import tomllib

    from judo.sysid.fitted_toml import fitted_toml

    config = {
        "task": "cartpole",
        "ros2": {"domain_id": 7, "joint_map": {"slider": "cart joint"}},
        "controller_config_overrides": {"cartpole": {"horizon": 1.0, "mppi": {"horizon": 0.8}}},
        "model_overrides": {
            "cartpole": {"body_mass": {"pole": 0.1}, "dof_damping": {"slider": 0.5}},
            "pendulum": {},
        },
        "plant_overrides": {"cartpole": {"body_mass": {"pole": 0.13}}},
    }
    fitted = {
        "body_mass": {"pole": np.array([0.13])},
        "geom_friction": {"pole": np.array([0.9, 0.005, 0.0001])},
    }
    text = fitted_toml("cartpole", fitted, ["a header"], config, ["a note"])
    expected = {**config, "model_overrides": {"pendulum": {}, "cartpole": {}}}
    # judo says "fitted"
    expected["sysid"] = {"cartpole": {"fitted": ["body_mass.pole", "geom_friction.pole"]}}
    expected["model_overrides"]["cartpole"] = {
        "body_mass": {"pole": 0.13},
        "dof_damping": {"slider": 0.5},
        "geom_friction": {"pole": [0.9, 0.005, 0.0001]},
    }
    assert tomllib.loads(text) == expected
    assert text.startswith("# a header\n") and text.endswith("# a note\n")


def test_a_centre_of_mass_is_fitted_across_zero(tmp_path):
    """A position is bounded by metres either way, not by a factor of its value: the pole's centre
    of mass moved from x = 0 to -0.02 m (a payload on one side) is found."""
    from judo.sysid.excite import main as excite_main

    log = tmp_path / "excite.h5"
    overrides = ["--plant-overrides", "body_ipos.pole=[-0.02, 0.0, 0.3]"]
    assert (
        excite_main(["--task", "cartpole", "--duration", "3", *overrides, "--out", str(log)]) == 0
    )
    out = tmp_path / "fitted.toml"
    assert (
        sysid_main(
            [str(log), "--task", "cartpole", "--params", "body_ipos.pole[0]", "--out", str(out)]
        )
        == 0
    )
    fitted = float(out.read_text().split("body_ipos.pole = [")[1].split(",")[0])
    assert fitted == pytest.approx(-0.02, abs=1e-3)
