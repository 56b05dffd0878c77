"""sysid on logs its old fit got confidently wrong: commands the plant applied a step late (a bridge
under load), a heavier pole whose inertia grew with its mass, a row of several entries named without
an index; every fifth window held out; and --out checked before the fit. Each log is real MuJoCo: a
multisine on a mismatched plant."""

import re

import mujoco
import numpy as np
import pytest

from judo.core.configuration.model_overrides import overridden
from judo.core.errors import ConfigError
from judo.recording.dataset import DatasetFile
from judo.sysid.excite import excitation_episode, multisine
from judo.sysid.parameters import FitParameter, parse_parameters
from judo.sysid.quality import noise_floor
from judo.sysid.sysid import main as sysid_main
from judo.sysid.windows import rms
from judo.tasks.cartpole import Cartpole

pytest.importorskip("h5py")
pytest.importorskip("scipy")
pytest.importorskip("colorama")

TRUE_MASS = 0.13
"""The plant's pole: x1.3 the cartpole MJCF's 0.1 kg."""


def write_log(path, late=0, inertia_factor=1.0, seconds=3.0):
    """A collect-layout log of cartpole driven by excite's multisine, its plant's pole TRUE_MASS
    (its inertia row times `inertia_factor`), each logged action applied by the plant `late` steps
    after it was served."""
    model = Cartpole().model
    pole = model.body("pole").id
    plant = overridden(
        model,
        {
            "body_mass": {"pole": np.array([TRUE_MASS])},
            "body_inertia": {"pole": model.body_inertia[pole] * inertia_factor},
        },
    )
    data = mujoco.MjData(plant)
    steps = round(seconds / plant.opt.timestep)
    served = multisine(plant.actuator_ctrlrange, np.arange(steps) * plant.opt.timestep, 0.5, 2.0, 0)
    states = np.zeros((steps, plant.nq + plant.nv))
    for step in range(steps):
        data.ctrl[:] = served[step - late] if step >= late else 0.0
        mujoco.mj_step(plant, data)
        states[step] = np.concatenate([data.qpos, data.qvel])
    episode = excitation_episode(0, plant, states, np.zeros((steps, plant.nsensordata)), served)
    DatasetFile(path, {"task": "cartpole", "plant_timestep": 0.01}).write_episode(episode)
    return path


def sysid(log, out, *args):
    """The report sysid writes beside `out` for `log` and `args`."""
    assert sysid_main([str(log), "--task", "cartpole", *args, "--out", str(out)]) == 0
    return out.with_suffix(".md").read_text()


def fitted(report, name):
    """(fitted value, verdict) of parameter `name` in a report's table."""
    row = re.search(
        rf"\| {re.escape(name)}[^|]* \| [\d.e-]+ \| ([\d.e-]+) \| [^|]+ \| ([^|]+) \|", report
    )
    assert row is not None, report
    return float(row.group(1)), row.group(2).strip()


def test_commands_applied_a_step_late_are_fitted_as_a_command_delay_and_the_mass_is_found(tmp_path):
    log = write_log(tmp_path / "late.h5", late=1)
    report = sysid(log, tmp_path / "fitted.toml", "--params", "body_mass.pole")
    mass, verdict = fitted(report, "body_mass.pole")
    assert mass == pytest.approx(TRUE_MASS, rel=1e-6) and verdict == "yes"
    assert "Command delay: 1 step (0.01 s): each logged action applied 1 step later" in report
    assert (
        "commands reached the plant 0.01 s (1 model steps) late"
        in (tmp_path / "fitted.toml").read_text()
    )
    # Paired with the actions as logged, the same log puts the mass 4% off, inside a tight interval.
    mass, _ = fitted(
        sysid(
            log, tmp_path / "as_logged.toml", "--params", "body_mass.pole", "--command-delay", "0"
        ),
        "body_mass.pole",
    )
    assert abs(mass - TRUE_MASS) > 0.02 * TRUE_MASS


def test_a_heavier_pole_fitted_by_its_mass_alone_is_flagged_and_its_inertia_named(tmp_path):
    """A pole of the same shape 1.3 times as heavy has 1.3 times its inertia: its mass alone cannot
    explain the log. The report says so and names the inertia; with the inertia's row (a factor on
    it) the fit is exact."""
    log = write_log(tmp_path / "heavy.h5", inertia_factor=1.3)
    out = tmp_path / "mass.toml"
    report = sysid(log, out, "--params", "body_mass.pole")
    _, verdict = fitted(report, "body_mass.pole")
    assert verdict.startswith("no: the fit explains little of the log")
    removed = float(re.search(r"the fit removed ([\d.]+)% of it", report).group(1))
    assert removed < 50
    assert re.search(r"Likely missing \(.*\): body_inertia\.pole \(\d+%\)", report), report
    assert "body_mass" not in out.read_text().split("[model_overrides.cartpole]")[1]
    report = sysid(log, tmp_path / "both.toml", "--params", "body_mass.pole", "body_inertia.pole")
    assert fitted(report, "body_mass.pole") == (pytest.approx(TRUE_MASS, rel=1e-6), "yes")
    assert fitted(report, "body_inertia.pole") == (pytest.approx(1.3, rel=1e-6), "yes")
    assert "the fit removed 100.0% of it" in report and "Likely missing" not in report


def test_every_fifth_window_is_held_out_and_its_error_reported_beside_the_fitted_ones(tmp_path):
    report = sysid(
        write_log(tmp_path / "run.h5"), tmp_path / "fitted.toml", "--params", "body_mass.pole"
    )
    counts = re.search(r"(\d+) windows of 5 steps \(0.05 s\) fitted, (\d+) more held out", report)
    assert (
        counts is not None
        and int(counts.group(2)) == (int(counts.group(1)) + int(counts.group(2))) // 5
    )
    before, after = (
        float(x)
        for x in re.search(r"On the windows held out: ([\d.e-]+) and ([\d.e-]+)\.", report).groups()
    )
    assert before > 1e-3 and after < 1e-9  # the fitted model predicts windows it never saw


def test_a_row_of_several_entries_without_an_index_is_one_factor_or_refused_with_its_entries():
    model = Cartpole().model
    assert parse_parameters(["body_inertia.pole"], model) == [
        FitParameter("body_inertia", "pole", None, True)
    ]
    assert parse_parameters(["body_inertia.pole[1]"], model) == [
        FitParameter("body_inertia", "pole", 1)
    ]
    with pytest.raises(ConfigError) as caught:
        parse_parameters(["body_ipos.pole"], model)
    assert str(caught.value) == (
        "--params body_ipos.pole: its 3 entries [0.0, 0.0, 0.3] are a position or "
        "orientation, which no factor fits; "
        "name the entries to fit: body_ipos.pole[0], body_ipos.pole[1], body_ipos.pole[2]"
    )
    with pytest.raises(ConfigError, match="the same entries are named twice"):
        parse_parameters(["body_inertia.pole", "body_inertia.pole[1]"], model)


def test_an_out_that_cannot_be_written_exits_2_before_the_fit_and_writes_nothing(
    tmp_path, capsys, monkeypatch
):
    import judo.sysid.fit as sysid_module

    def no_fit(*args, **kwargs):
        raise AssertionError("the fit ran before --out was checked")

    monkeypatch.setattr(sysid_module, "fit", no_fit)
    log = write_log(tmp_path / "run.h5", seconds=0.5)
    (tmp_path / "taken.md").mkdir()  # where the report of --out taken.toml would go
    for out, message in [
        ("/proc/nope/f.toml", "--out: cannot write in '/proc'"),
        (str(tmp_path / "taken.toml"), "is a folder; give a file path"),
    ]:
        with pytest.raises(SystemExit) as caught:
            sysid_main([str(log), "--task", "cartpole", "--params", "body_mass.pole", "--out", out])
        err = capsys.readouterr().err
        assert caught.value.code == 2 and err.count("\n") == 1 and message in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.h5", "taken.md"]


def test_the_noise_floor_is_the_white_noise_under_a_smooth_drift():
    """A model's error drifts smoothly over a window (its curvature per step far below the noise);
    white noise does not: the floor finds the noise under a drift 10 times its size, and almost
    nothing in the drift alone."""
    rng = np.random.default_rng(0)
    steps = np.arange(10)[None, :, None]
    drift = (0.02 * steps + 0.001 * steps**2) * rng.normal(size=(400, 1, 3))
    noise = 0.01 * rng.normal(size=(400, 10, 3))
    assert rms(drift) > 10 * 0.01
    assert noise_floor(drift + noise) == pytest.approx(0.01, rel=0.1)
    assert noise_floor(drift) < 0.01 * rms(drift)


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["--command-delay", "soon"],
            "--command-delay takes auto or a whole number of steps from 0 to 100, got 'soon'",
        ),
        (
            ["--command-delay", "2", "--fit-delay"],
            "--command-delay 2 and --fit-delay both delay the actions; give one",
        ),
    ],
)
def test_a_command_delay_sysid_cannot_use_exits_2_in_one_line(tmp_path, capsys, args, message):
    with pytest.raises(SystemExit) as caught:
        sysid_main(
            [
                str(tmp_path / "run.h5"),
                "--task",
                "cartpole",
                "--params",
                "body_mass.pole",
                *args,
                "--out",
                str(tmp_path / "f.toml"),
            ]
        )
    err = capsys.readouterr().err
    assert caught.value.code == 2 and err == f"error: {message}\n"
    assert list(tmp_path.iterdir()) == []
