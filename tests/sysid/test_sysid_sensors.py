"""python -m judo excite --system and sysid from measured sensors: a user's System driven through the CLI (examples/06's
robot with noisy, late encoders, and Systems defined here), a stop that halts it and keeps the log,
and fits that compare the measured sensors, each window from the logged estimate refined to its own
measurements."""  # noqa: E501

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from judo.collection.episode import collect_episode
from judo.core.reading import SystemState
from judo.evaluation.seeded import EpisodeSpec
from judo.evaluation.sensing import Sensing
from judo.loop.system import System
from judo.recording.dataset import DatasetFile
from judo.sysid.excite import main as excite_main
from judo.sysid.sysid import main as sysid_main
from judo.tasks.cartpole import MODEL_PATH

h5py = pytest.importorskip("h5py")
pytest.importorskip("scipy")
pytest.importorskip("colorama")

ROOT = Path(__file__).resolve().parents[2]


def fitted_mass(report: str) -> float:
    """The fitted body_mass.pole of a sysid report."""
    found = re.search(r"\| body_mass.pole \| 0.1 \| ([\d.e-]+) \| ± [\d.e-]+ \| yes \|", report)
    assert found is not None, report
    return float(found.group(1))


@pytest.mark.slow
def test_excite_drives_examples_06_robot_through_the_cli_and_sysid_fits_its_pole_from_the_noisy_encoders(  # noqa: E501
    tmp_path, capsys
):
    """examples/06's LaggyNoisyCartpole (pole 10% heavier, encoders only, noisy and 20 ms late,
    motor 10 ms late), loaded as module:Class from its folder: the log holds no state, its measured
    encoders with their ages and the EKF's estimate; the fit compares the encoders and finds the
    pole's mass and the motor's lag."""
    log = tmp_path / "robot.h5"
    argv = [
        "excite",
        "--task",
        "cartpole",
        "--system",
        "06_hardware_system:LaggyNoisyCartpole",
        "--duration",
        "5",
    ]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    run = subprocess.run(
        [sys.executable, "-m", "judo", *argv, "--out", str(log)],
        cwd=ROOT / "examples",
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    assert (
        "through LaggyNoisyCartpole (its measured sensors and the estimator's state)" in run.stdout
    )
    assert "applied the task's safe action" in run.stdout  # it defines no halt()
    with h5py.File(log, "r") as file:
        demo = file["data/demo_0"]
        assert np.isnan(demo["obs/qpos"][:]).all()  # the robot reports no state
        measured, age = demo["obs/measured"][:], demo["obs/measured_age"][:]
        assert measured.shape == (500, 2) and np.isfinite(measured).all()
        # the encoders arrive 20 ms after they are taken
        np.testing.assert_allclose(age[5:], 0.02, atol=1e-9)
        assert np.isfinite(demo["obs/estimate_qpos"][:]).all()
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
    assert "windows of 50 steps (0.5 s)" in report  # the default window when comparing sensors
    assert (
        "Compared: the measured sensors" in report
        and "each window from the logged estimate" in report
    )
    assert fitted_mass(report) == pytest.approx(0.11, rel=0.03)
    delay = re.search(r"\| delay \(s\) \| 0 \| ([\d.e-]+) \| ± [\d.e-]+ \| yes \|", report)
    assert delay is not None and float(delay.group(1)) == pytest.approx(0.01, abs=0.003)
    capsys.readouterr()


@pytest.mark.slow
def test_a_collect_with_observe_sensors_on_a_heavier_pole_is_fitted_from_the_measured_sensors(
    tmp_path,
):
    """collect --observe sensors (noisy encoders, 20 ms late) on a plant whose pole is 0.13 kg,
    planning with 0.1 kg: the fit compares the measured sensors, not the plant's true state the
    simulator also logged."""
    sensing = Sensing("sensors", noise=0.005, delay=0.02)
    spec = EpisodeSpec(
        "cartpole", "mppi", 3.0, sensing=sensing, plant_overrides=("body_mass.pole=0.13",)
    )
    outcome = collect_episode(spec, 0)
    assert outcome.failure is None
    np.testing.assert_allclose(outcome.episode.measured_age[5:], 0.02, atol=1e-9)
    log = tmp_path / "run.h5"
    DatasetFile(
        log, {"task": "cartpole", "optimizer": "mppi", "plant_timestep": 0.01}
    ).write_episode(outcome.episode)
    out = tmp_path / "fitted.toml"
    assert (
        sysid_main(
            [str(log), "--task", "cartpole", "--params", "body_mass.pole", "--out", str(out)]
        )
        == 0
    )
    report = (tmp_path / "fitted.md").read_text()
    assert "Compared: the measured sensors" in report
    assert fitted_mass(report) == pytest.approx(0.13, rel=0.10)


class RecordingCartpole(System):
    """judo's cart-pole model as a robot that reports its full state, and, after STOP_AFTER steps,
    asks its own process to stop (SIGINT, as a Ctrl-C); it keeps every action applied and every
    halt()."""

    STOP_AFTER = 50
    HALTS = True
    applied: list[np.ndarray] = []
    halts: list[int] = []

    def __init__(self, task: object = None) -> None:
        del task
        self.model = mujoco.MjModel.from_xml_path(str(MODEL_PATH))
        self.data = mujoco.MjData(self.model)
        self.timestep = float(self.model.opt.timestep)
        self.steps = 0
        type(self).applied.clear()
        type(self).halts.clear()

    def reset(self) -> None:
        mujoco.mj_resetData(self.model, self.data)

    def read_state(self) -> SystemState:
        return SystemState(np.concatenate([self.data.qpos, self.data.qvel]), float(self.data.time))

    def apply(self, action: np.ndarray) -> None:
        self.data.ctrl[:] = action
        type(self).applied.append(np.array(action))

    def step(self) -> None:
        mujoco.mj_step(self.model, self.data)
        self.steps += 1
        if self.steps == self.STOP_AFTER:
            os.kill(os.getpid(), signal.SIGINT)

    def halt(self) -> bool:
        type(self).halts.append(self.steps)
        return self.HALTS


class UnhaltableCartpole(RecordingCartpole):
    """RecordingCartpole without a halt of its own: excite applies the task's safe action
    instead."""

    HALTS = False


@pytest.mark.parametrize("system_class, said", [(RecordingCartpole, "halted it (halt())"),
                                                 (UnhaltableCartpole, "applied the "
                                                                      "task's safe action")])  # fmt: skip  # noqa: E501
def test_a_stop_halts_the_system_and_keeps_what_was_logged(tmp_path, capsys, system_class, said):
    log = tmp_path / "stopped.h5"
    argv = [
        "--task",
        "cartpole",
        "--system",
        f"{__name__}:{system_class.__name__}",
        "--duration",
        "3",
    ]
    assert excite_main([*argv, "--out", str(log)]) == 130
    printed = capsys.readouterr().out
    assert f"stopped after 50 of 300 steps; {said}; wrote the 50 steps" in printed
    assert system_class.halts == [50]  # asked once, after the step under way
    if system_class is UnhaltableCartpole:
        # cartpole's safe action: the motor off
        np.testing.assert_array_equal(system_class.applied[-1], [0.0])
    with h5py.File(log, "r") as file:
        demo = file["data/demo_0"]
        assert demo["actions"].shape == (50, 1) and demo["obs/qpos"].shape == (50, 2)
        assert np.isfinite(demo["obs/qpos"][:]).all()  # the state it reported
        assert "measured" not in demo["obs"] and "estimate_qpos" not in demo["obs"]
        np.testing.assert_array_equal(demo["actions"][:], np.array(system_class.applied[:50]))


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--system", "nowhere:Robot"], "--system nowhere:Robot: cannot import module 'nowhere'"),
        (
            ["--system", "robot"],
            "--system expects ros2, sim, unitree or module:Class (a System subclass), got 'robot'",
        ),
        (
            [
                "--system",
                f"{__name__}:RecordingCartpole",
                "--plant-overrides",
                "body_mass.pole=0.2",
            ],
            "--plant-overrides set judo's simulated plant; --system "
            f"{__name__}:RecordingCartpole is its own plant",
        ),
    ],
)
def test_excite_system_mistakes_are_one_line_and_write_nothing(tmp_path, capsys, argv, message):
    out = tmp_path / "never.h5"
    with pytest.raises(SystemExit) as caught:
        excite_main(["--task", "cartpole", *argv, "--out", str(out)])
    err = capsys.readouterr().err
    assert caught.value.code == 2 and err.count("\n") == 1 and message in err
    assert not out.exists()


def test_compare_sensors_on_a_log_of_states_says_what_the_log_holds(tmp_path, capsys):
    log = tmp_path / "excite.h5"
    assert excite_main(["--task", "cartpole", "--duration", "0.5", "--out", str(log)]) == 0
    with pytest.raises(SystemExit) as caught:
        sysid_main([str(log), "--task", "cartpole", "--params", "body_mass.pole", "--compare", "sensors",  # noqa: E501
                    "--out", str(tmp_path / "fitted.toml")])  # fmt: skip
    err = capsys.readouterr().err
    assert caught.value.code == 2
    assert (
        "excite.h5:demo_0: the log holds no measured sensors (obs/measured) to compare; its "
        "plant reported its " in err
    )
    assert not (tmp_path / "fitted.toml").exists()


def test_each_measured_value_is_compared_at_the_step_it_was_taken():
    """A rehearsed sensor at 50 Hz under a 0.01 s model, 20 ms late, noiseless: read after every
    step (held between samples), logged with its age, and placed back at every other step, where it
    equals the plant's joint positions (cartpole's measured sensors) of that step."""
    from judo.core.configuration.registry import make_task
    from judo.sysid.data import Episode
    from judo.sysid.windows import taken_samples

    outcome = collect_episode(
        EpisodeSpec("cartpole", "ps", 0.3, sensing=Sensing("sensors", delay=0.02, rate=50.0)), 0
    )
    e = outcome.episode
    episode = Episode(
        "e", e.qpos, e.qvel, e.actions, e.measured, e.measured_age, e.estimate, e.measured_sensors
    )
    # row n: taken after n steps
    samples = taken_samples(episode, make_task("cartpole").measured, 0.01)
    taken = np.flatnonzero(np.isfinite(samples).all(axis=1))
    assert taken[0] == 0 and (np.diff(taken) == 2).all() and taken[-1] >= len(e.qpos) - 3
    # qpos after step n - 1
    np.testing.assert_allclose(samples[taken[1:]], e.qpos[taken[1:] - 1], atol=1e-12)


def test_sim_is_judos_simulator_by_name():
    from judo.system_choice import SystemOptions, build_system

    # the caller builds judo's own plant
    assert build_system(SystemOptions("sim"), "cartpole") is None
