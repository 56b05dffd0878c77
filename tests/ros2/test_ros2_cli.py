"""`--system`, `--record` and `python -m judo plant` on the command line, and the "done when" run: a
robot process with no judo code (examples/10_ros2_robot.py) swung up and balanced by `python -m judo
--system ros2`."""

import signal
import subprocess
import sys

import pytest

pytest.importorskip("cyclonedds")

from ros2_links import ROOT, env, free_domain, stop_process

from judo.loop.system import System
from judo.ros2 import plant
from judo.runtime import launch
from judo.system_choice import SystemOptions, build_system, system_class


def one_line_error(capsys, argv: list[str], main=launch.main) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    return err


def test_a_bad_system_or_record_is_one_line_naming_the_choices(capsys, tmp_path):
    err = one_line_error(capsys, ["--task", "cartpole", "--headless", "--system", "ros3"])
    assert (
        "--system expects ros2, sim, unitree or module:Class (a System subclass), got 'ros3'" in err
    )
    err = one_line_error(
        capsys, ["--task", "cartpole", "--headless", "--system", "judo.loop.system:SystemState"]
    )
    assert "expected a System subclass 'SystemState' in judo.loop.system, got SystemState" in err
    err = one_line_error(
        capsys, ["--task", "cartpole", "--headless", "--record", str(tmp_path / "run.mcap")]
    )
    assert "give it with --system ros2" in err
    err = one_line_error(
        capsys,
        [
            "--task",
            "cartpole",
            "--headless",
            "--system",
            "ros2",
            "--ros2.domain-id",
            str(free_domain()),
            "--ros2.wait-s",
            "0.2",
        ],
    )
    assert (
        "no valid sensor_msgs/JointState on rt/joint_states" in err and "['slider', 'hinge']" in err
    )
    err = one_line_error(
        capsys, ["--task", "cartpole", "--system", "ros2", "--ros2.domain-id", "400"]
    )
    assert "the DDS domain id must be 0..232, got 400" in err


def test_a_users_system_class_is_loaded_by_module_and_class_and_built_on_the_task(
    tmp_path, monkeypatch
):
    (tmp_path / "my_robot.py").write_text(
        "from judo.loop.system import MujocoSystem\nclass MyRobot(MujocoSystem):\n    pass\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    assert issubclass(system_class("my_robot:MyRobot"), System)
    robot = build_system(SystemOptions(system="my_robot:MyRobot"), "cartpole")
    assert type(robot).__name__ == "MyRobot" and type(robot.task).__name__ == "Cartpole"
    assert robot.read_state().state.shape == (4,)


def test_the_plant_refuses_faults_out_of_range_in_one_line(capsys):
    err = one_line_error(capsys, ["--drop", "1.5"], plant.main)
    assert err == "python -m judo plant: --drop must be a fraction 0..1, got 1.5"
    err = one_line_error(capsys, ["--task", "cartpol"], plant.main)
    assert "unknown task 'cartpol'; valid tasks are:" in err and "cartpole" in err
    absurd = {  # accepted before, and run to exit 0 (a seed of -1 was numpy's ValueError, exit 1)
        ("--seed", "-1"): "--seed must be an integer from 0 to 2**63 - 1, got -1",
        ("--rate-hz", "1e300"): "--rate-hz must be above 0 and at most 10000 Hz, got 1e+300",
        ("--duration", "-1"): "--duration must be in (0, 604800] s (a week), got -1.0",
        ("--latency-ms", "1e300"): "--latency-ms must be from 0 to 10000 ms, got 1e+300",
        ("--jitter-ms", "nan"): "--jitter-ms must be from 0 to 10000 ms, got nan",
    }
    handlers = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    for argv, message in absurd.items():
        assert one_line_error(capsys, list(argv), plant.main) == f"python -m judo plant: {message}"
    # the caller's, again
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == handlers


@pytest.mark.slow
def test_a_robot_with_no_judo_code_is_swung_up_and_balanced_over_ros2():
    domain = free_domain()
    robot = subprocess.Popen(
        [sys.executable, str(ROOT / "examples" / "10_ros2_robot.py"), "--seconds", "60"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env(domain),
        cwd=ROOT,
    )
    try:
        assert "publishing rt/joint_states" in robot.stdout.readline()
        app = subprocess.run(
            [
                sys.executable,
                "-m",
                "judo",
                "--task",
                "cartpole",
                "--system",
                "ros2",
                "--headless",
                "--duration",
                "9",
            ],
            capture_output=True,
            text=True,
            env=env(domain),
            cwd=ROOT,
            timeout=120,
        )
        assert app.returncode == 0, app.stderr
        out, _ = robot.communicate(timeout=10)  # it stops 1 s after the last command
    finally:
        if robot.poll() is None:
            stop_process(robot)
    assert "robot: upright " in out, out
    fraction = float(out.split("robot: upright ")[1].split()[0])
    assert fraction >= 0.8, out


def test_without_the_ros2_extra_both_commands_say_what_to_install_in_one_line(capsys, monkeypatch):
    for name in ("cyclonedds", "cyclonedds.domain", "mcap", "mcap.writer"):
        # makes the import raise ImportError, as without the extra
        monkeypatch.setitem(sys.modules, name, None)
    for name in ("judo.ros2.bridge", "judo.ros2.messages", "judo.ros2.link", "judo.ros2.mcap_log"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    err = one_line_error(capsys, ["--task", "cartpole", "--headless", "--system", "ros2"])
    assert (
        "the ROS 2 bridge needs the optional extra judo-mpc[ros2]" in err and "pip install" in err
    )
    err = one_line_error(capsys, ["--task", "cartpole"], plant.main)
    assert "python -m judo plant needs the optional extra judo-mpc[ros2]" in err


def test_import_judo_and_its_app_import_no_dds():
    code = (
        "import sys, judo, judo.runtime.launch; print(sorted(m for m in sys.modules if "
        "'cyclonedds' in m or 'mcap' in m))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env()
    ).stdout
    assert out.strip() == "[]"


def test_the_config_file_names_the_system_and_the_bridges_settings_under_the_flags(
    capsys, tmp_path
):
    domain = free_domain()
    config = tmp_path / "judo.toml"
    config.write_text(
        f'task = "cartpole"\nsystem = "ros2"\n[ros2]\ndomain_id = {domain}\nwait_s = 30\n'
        'joint_states = "/robot/joint_states"\njoint_map = { slider = "cart_joint" }\n'
    )
    err = one_line_error(capsys, ["--config", str(config), "--headless", "--ros2.wait-s", "0.2"])
    assert (
        f"no valid sensor_msgs/JointState on rt/robot/joint_states in DDS domain {domain} within "
        "0.2 s"
    ) in err
    assert "['cart_joint', 'hinge']" in err  # the file's joint map
    config.write_text('system = "ros2"\n[ros2]\ndomian_id = 3\n')
    err = one_line_error(capsys, ["--config", str(config), "--headless"])
    assert (
        "the config file's [ros2]: unknown field 'domian_id'; valid fields are: domain_id," in err
    )
