"""The bridge's MCAP log read back (judo.ros2.mcap_read): a real log of the bridge driving a plant
process with a heavier pole over DDS holds the plant's states and the commands sent, `replay` loads
it, and `sysid` finds the pole's mass from it; logs it cannot use are one-line errors naming what
they hold."""

import re
import subprocess
import sys

import mujoco
import numpy as np
import pytest

pytest.importorskip("cyclonedds")
pytest.importorskip("mcap_ros2.decoder")

from ros2_links import env, free_domain, record_multisine, start_plant, stop_process

from judo.core.configuration.config_file import load_config
from judo.core.configuration.model_overrides import overridden
from judo.core.configuration.registry import make_task
from judo.ros2 import link
from judo.ros2.bridge_log import BridgeLogError
from judo.ros2.joints import JointLayout
from judo.ros2.mcap_log import McapLog
from judo.ros2.mcap_read import read_bridge_log
from judo.runtime.gui.replay import Replay
from judo.runtime.gui.replay import main as replay_main
from judo.sysid.sysid import main as sysid_main
from judo.tasks.cartpole import Cartpole

TRUE_MASS = 0.13
"""The plant process's pole mass: x1.3 the cartpole MJCF's 0.1."""
SECONDS = 3.0


@pytest.fixture(scope="module")
def bridge_log(tmp_path_factory):
    """(path, commands (C, 1) sent): the bridge, as the app builds it with --record, driving a
    cartpole plant process with a heavier pole by a multisine at its 100 Hz for 3 s."""
    path = tmp_path_factory.mktemp("mcap") / "run.mcap"
    return path, log_multisine(path, round(SECONDS * 100))


def log_multisine(path, steps: int, *plant_args: str) -> np.ndarray:
    """Drive a cartpole plant process with the heavier pole (more `plant_args` for `python -m judo
    plant`) through the bridge, recording to `path`, by `steps` commands of a multisine at the
    bridge's 100 Hz; returns them (C, 1)."""
    domain = free_domain()
    proc = start_plant(domain, "--plant-overrides", f"body_mass.pole={TRUE_MASS}", *plant_args)
    try:
        return record_multisine(path, domain, steps)
    finally:
        stop_process(proc)


@pytest.mark.slow
def test_the_log_reads_back_as_the_plants_states_under_the_commands_applied_and_sent(bridge_log):
    path, sent = bridge_log
    log = read_bridge_log(path)
    assert log.task == "cartpole" and log.topics["joint_states"] == "/joint_states"
    np.testing.assert_array_equal(log.commands, sent)  # every command, in order, as written
    assert len(log.times) > 100 and (np.diff(log.times) > 0).all()
    # on the plant's steps
    np.testing.assert_allclose(log.times / 0.01, np.round(log.times / 0.01), atol=1e-6)
    # Each logged state is the plant's own: one step of the plant's model (the heavier pole) from
    # the row before, under the action the reader holds for it, lands on it (float64 on the wire, so
    # to rounding).
    plant = overridden(
        make_task("cartpole").sim_model, {"body_mass": {"pole": np.array([TRUE_MASS])}}
    )
    data = mujoco.MjData(plant)

    def exact_fraction(offset: int) -> tuple[float, int]:
        """The fraction of steps that re-simulate to rounding with each row's action read `offset`
        rows late."""
        errors = []
        for rows in log.segments():
            for row in range(rows.start + 1 + max(offset, 0), rows.stop + min(offset, 0)):
                data.qpos[:], data.qvel[:] = log.qpos[row - 1], log.qvel[row - 1]
                data.ctrl[:] = log.actions[row - offset]
                mujoco.mj_step(plant, data)
                errors.append(
                    np.abs(np.r_[data.qpos - log.qpos[row], data.qvel - log.qvel[row]]).max()
                )
        return float(np.mean(np.array(errors) < 1e-9)), len(errors)

    # Paired with the commands the plant reported applying, every step re-simulates to rounding,
    # however loaded.
    assert log.source == "applied"
    exact, steps = exact_fraction(0)
    assert steps > 50 and exact == 1.0, (exact, steps)
    # Paired with the commands sent (a log without the applied ones): on an idle machine the row's
    # own command explains every step. On loaded cores some commands reach the plant after its step,
    # which then ran under the command before: those steps re-simulate with the action read one row
    # off (0 to 0.32 of them with two cores kept busy, up to 0.77 in one full CI run), which depends
    # on the load, not on the reader. So the states are the plant's own under the commands sent when
    # nearly every step is explained by its row's command or a neighbour's, and the rows are paired
    # when commands two rows off explain almost none (the multisine changes every step).
    log.applied = log.applied[:0]
    log.actions = log.actions_at(log.times)
    exact = exact_fraction(0)[0]
    off = max(exact_fraction(1)[0], exact_fraction(-1)[0])
    far = max(exact_fraction(2)[0], exact_fraction(-2)[0])
    assert exact + off >= 0.9 and far < 0.1, (exact, off, far)


@pytest.mark.slow
def test_replay_loads_the_log_as_one_demo_on_the_robots_clock(bridge_log):
    path, _ = bridge_log
    log = read_bridge_log(path)
    replay = Replay(path)  # the GUI's loading, without serving it
    assert replay.env_args["task"] == "cartpole" and list(replay.demos) == [0]
    np.testing.assert_array_equal(replay.demo.qpos, log.qpos)
    np.testing.assert_allclose(replay.demo.times, log.times - log.times[0] + 0.01)
    assert replay.demo.success is None and not replay.demo.has_traces
    assert [replay._row(t) for t in replay.demo.times[[0, 5, -1]]] == [0, 5, len(log.times) - 1]


@pytest.mark.slow
def test_sysid_finds_the_plants_pole_mass_from_the_log(bridge_log, tmp_path, capsys):
    path, _ = bridge_log
    out = tmp_path / "fitted.toml"
    assert (
        sysid_main(
            [str(path), "--task", "cartpole", "--params", "body_mass.pole", "--out", str(out)]
        )
        == 0
    )
    assert "| body_mass.pole | 0.1 | 0.1" in capsys.readouterr().out
    load_config(out)
    model = make_task("cartpole").model
    assert model.body_mass[model.body("pole").id] == pytest.approx(TRUE_MASS, rel=0.05)


@pytest.mark.slow
def test_sysid_compares_a_robot_publishing_every_fourth_model_step_at_its_joint_states(
    tmp_path, capsys
):
    """The plant process publishing its JointStates at 25 Hz under cartpole's 0.01 s model (every
    4th step), the bridge commanding at 100 Hz: the log's rows lie 4 steps apart (more where the
    bridge missed one); the fit rolls every step out under the commands in force and compares the
    steps that have a joint state."""
    path = tmp_path / "slow.mcap"
    log_multisine(path, 300, "--rate-hz", "25")
    log = read_bridge_log(path)
    gaps = np.round(np.diff(log.times) / 0.01).astype(int)
    assert np.median(gaps) == 4 and not (gaps == 1).any()  # never one step apart: refused before
    out = tmp_path / "fitted.toml"
    assert (
        sysid_main(
            [str(path), "--task", "cartpole", "--params", "body_mass.pole", "--out", str(out)]
        )
        == 0
    )
    found = re.search(
        r"\| body_mass.pole \| 0.1 \| ([\d.e-]+) \| ± [\d.e-]+ \| yes \|", capsys.readouterr().out
    )
    assert found is not None and float(found.group(1)) == pytest.approx(TRUE_MASS, rel=0.05)


def write_log(
    path, joint_map=(), joints=True, commands=True, metadata=None, stamps=20, every=0.01, applied=()
):
    """A log written with the bridge's own writer, no DDS: `stamps` JointStates (named through
    `joint_map`, where `joints`) `every` seconds apart, each followed by a command where `commands`;
    first the plant's records of the commands it applied, (stamp, values) each of `applied`."""
    log = McapLog(path, {"task": "cartpole"} if metadata is None else metadata)
    layout = JointLayout.of(Cartpole().model, joint_map)
    for stamp, values in applied:
        log.write(
            "/judo/commands_applied",
            link.applied(["slide"], np.array(values), stamp),
            round(stamp * 1e9),
        )
    for step in range(1, stamps + 1):
        if joints:
            message = link.joint_state(layout, np.array([0.1, 3.0]), np.zeros(2), every * step)
            log.write("/joint_states", message, step * 10_000_000)
        if commands:
            log.write("/judo/commands", link.commands(np.array([0.5])))
    log.close()
    return path


def test_each_row_is_paired_with_the_command_the_plant_applied_before_it_and_else_with_those_sent(
    tmp_path,
):
    # The plant applied 1.0 from 0.05 s and -1.0 from 0.10 s on (the bridge sent 0.5 each step): the
    # step ending at a row ran under the latest applied at its start, stamped before the row.
    path = write_log(tmp_path / "applied.mcap", applied=[(0.05, [1.0]), (0.10, [-1.0])])
    log = read_bridge_log(path)
    assert log.source == "applied" and log.topics["applied"] == "/judo/commands_applied"
    np.testing.assert_array_equal(log.applied_times, [0.05, 0.10])
    rows = {round(t * 100): a[0] for t, a in zip(log.times, log.actions, strict=True)}
    assert np.isnan(rows[5]) and rows[6] == rows[10] == 1.0 and rows[11] == rows[20] == -1.0, rows
    np.testing.assert_array_equal(
        log.actions_at(np.array([0.0501, 0.1, 0.1001])), [[1.0], [1.0], [-1.0]]
    )
    # A log without them (an older bridge's) is paired with the commands sent.
    log = read_bridge_log(write_log(tmp_path / "sent.mcap"))
    assert log.source == "sent" and len(log.applied) == 0 and (log.actions[1:] == 0.5).all()
    with pytest.raises(BridgeLogError) as caught:
        read_bridge_log(write_log(tmp_path / "wide.mcap", applied=[(0.05, [1.0, 2.0])]))
    assert str(caught.value) == (
        f"{tmp_path / 'wide.mcap'}: applied commands on /judo/commands_applied of [2] "
        "values; the task's model has 1 "
        "actuators"
    )


def corrupt(path):
    path.write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 4)
    return path


@pytest.mark.parametrize(
    "case, message",
    [
        (
            "no_joint_states",
            "no_joint_states.mcap: no sensor_msgs/msg/JointState on /joint_states; "
            "the log holds /judo/commands "
            "(std_msgs/msg/Float64MultiArray)",
        ),
        (
            "other_joints",
            "other_joints.mcap: its joint states name the joints ['cart', 'pole']; "
            "cartpole's model has ['slider', "
            "'hinge'] (missing ['slider', 'hinge'], unknown ['cart', 'pole'])",
        ),
        (
            "no_task",
            "no_task.mcap: the log does not name its task (the bridge's record does); give --task",
        ),
        ("corrupt", "corrupt.mcap: not a readable MCAP log"),
        ("empty", "empty.mcap: the file is empty"),
    ],
)
def test_logs_replay_cannot_play_are_one_line_errors_naming_what_they_hold(
    tmp_path, capsys, case, message
):
    logs = {
        "no_joint_states": lambda p: write_log(p, joints=False),
        "other_joints": lambda p: write_log(p, joint_map=("slider=cart", "hinge=pole")),
        "no_task": lambda p: write_log(p, metadata={}),
        "corrupt": corrupt,
        "empty": lambda p: p.touch() or p,
    }
    path = logs[case](tmp_path / f"{case}.mcap")
    with pytest.raises(SystemExit) as caught:
        replay_main([str(path), "--port", "8499"])
    assert caught.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and message in err, err


def test_sysid_refuses_a_log_without_commands_or_of_another_task_and_writes_nothing(
    tmp_path, capsys
):
    cases = [
        (
            write_log(tmp_path / "quiet.mcap", commands=False),
            "cartpole",
            "pole",
            "no std_msgs/msg/Float64MultiArray",
        ),
        (
            write_log(tmp_path / "run.mcap"),
            "acrobot",
            "upper_arm",
            "a log of task 'cartpole', not of --task 'acrobot'",
        ),
        (
            write_log(tmp_path / "offgrid.mcap", every=0.015),
            "cartpole",
            "pole",
            "offgrid.mcap: no two joint states a whole number of model steps (0.01 s, at "
            "most 100) apart with a "
            "command in force (they are 0.015 s apart); the robot must publish on the "
            "model's step grid",
        ),
    ]
    for path, task, body, message in cases:
        argv = [
            str(path),
            "--task",
            task,
            "--params",
            f"body_mass.{body}",
            "--out",
            str(tmp_path / "o/f.toml"),
        ]
        with pytest.raises(SystemExit) as caught:
            sysid_main(argv)
        assert caught.value.code == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "o").exists()
    # A log of the bridge without --task in a log that names none: `--task` on replay fills it in.
    replay = Replay(write_log(tmp_path / "anonymous.mcap", metadata={}), task="cartpole")
    assert replay.env_args["task"] == "cartpole" and replay.demo.qpos.shape == (20, 2)
    # A robot's own joint names are mapped back by the joint map the bridge wrote into the log.
    renamed = {"task": "cartpole", "joint_map": "slider=cart,hinge=pole"}
    log = read_bridge_log(
        write_log(tmp_path / "renamed.mcap", ("slider=cart", "hinge=pole"), metadata=renamed)
    )
    np.testing.assert_array_equal(log.qpos, np.tile([0.1, 3.0], (20, 1)))


def test_the_reader_needs_no_dds_and_without_mcap_says_what_to_install(tmp_path):
    path = write_log(tmp_path / "run.mcap")
    code = (
        "import sys; sys.modules['cyclonedds'] = None\n"  # any import of cyclonedds now fails
        "from judo.ros2.bridge_log import BridgeLogError\n"
        "from judo.ros2.mcap_read import read_bridge_log\n"
        f"log = read_bridge_log({str(path)!r})\n"
        "print(log.task, log.qpos.shape, log.commands.tolist()[:2])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env())
    assert out.stdout == "cartpole (20, 2) [[0.5], [0.5]]\n", out.stderr
    code = (
        "import sys; sys.modules['mcap.reader'] = None\nfrom judo.runtime.gui.replay import "
        "main\nmain([sys.argv[1]])"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(path)], capture_output=True, text=True, env=env()
    )
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert "python -m judo replay LOG.mcap needs the optional extra judo-mpc[ros2]" in out.stderr
    assert 'pip install -e ".[ros2]"' in out.stderr
