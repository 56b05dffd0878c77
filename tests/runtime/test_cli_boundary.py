"""The command-line boundary of every command (the app, evaluate, benchmark, tune, collect, replay),
as one table: each row runs `python -m judo` in a subprocess and expects an exit status, a one-line
message, and no traceback and no hang. Bad config files, user classes and rewards that raise, sizes
and sensing values beyond their bounds, output paths that cannot be written, HDF5 files that are not
judo's or are broken, and Ctrl-C."""

import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import judo

SRC = str(Path(judo.__file__).resolve().parents[1])
TIMEOUT = 180.0
"""Seconds a row may take before it counts as a hang."""

USER_CLASSES = """
from dataclasses import dataclass

import numpy as np

from judo.tasks.cartpole import Cartpole, CartpoleConfig


@dataclass
class BadConfig(CartpoleConfig):
    def __post_init__(self):
        raise RuntimeError("config init failed")


class InitFails(Cartpole):
    def __init__(self, *args, **kwargs):
        raise RuntimeError("cannot build the task")


class RewardFails(Cartpole):
    def reward(self, *args, **kwargs):
        raise ZeroDivisionError("reward blew up")


class RewardFailsBelow(Cartpole):
    def reward(self, states, sensors, controls, config, *args, **kwargs):
        if config.w_vertical < 3.0:
            raise ValueError("w_vertical too low for this test")
        return super().reward(states, sensors, controls, config, *args, **kwargs)


class NoSensors(Cartpole):
    measured_sensors = ()


class RewardStrings(Cartpole):
    def reward(self, states, *args, **kwargs):
        return np.array(["x"] * states.shape[0])
"""


def custom_task(task: str, config: str = "judo.tasks.cartpole.CartpoleConfig") -> str:
    return f'[custom_tasks.bad]\ntask = "{task}"\nconfig = "{config}"\n'


FILES: dict[str, str | bytes] = {
    "user_classes.py": USER_CLASSES,
    "init_fails.toml": custom_task("user_classes.InitFails"),
    "config_fails.toml": custom_task("judo.tasks.cartpole.Cartpole", "user_classes.BadConfig"),
    "reward_fails.toml": custom_task("user_classes.RewardFails"),
    "reward_strings.toml": custom_task("user_classes.RewardStrings"),
    "reward_fails_above.toml": custom_task("user_classes.RewardFailsBelow"),
    "no_sensors.toml": custom_task("user_classes.NoSensors"),
    "bigint.toml": "[task_config_overrides.cartpole]\nw_vertical = " + "9" * 400 + "\n",
    "unknown_task.toml": "[controller_config_overrides.no_such_task]\nhorizon = 1.0\n",
    "binary.toml": b"\x00\x01\x02binary\xff\xfe",
    "latin1.toml": 'task = "caf\xe9"\n'.encode("latin-1"),
    "big.toml": "# " + "x" * 1_100_000 + "\n",
    "a_file": "not a folder",
}

APP = ("--headless", "--duration", "0.05")
EVALUATE = (
    "evaluate",
    "--task",
    "cartpole",
    "--optimizer",
    "ps",
    "--seeds",
    "1",
    "--duration",
    "0.05",
)
BENCHMARK = (
    "benchmark",
    "--tasks",
    "cartpole",
    "--optimizers",
    "ps",
    "--samples",
    "2",
    "--warmup",
    "0",
)
TUNE = (
    "tune",
    "--task",
    "cartpole",
    "--optimizer",
    "ps",
    "--trials",
    "1",
    "--seeds",
    "1",
    "--duration",
    "0.05",
)
COLLECT = tuple(
    "collect --task cartpole --optimizer ps --episodes 1 --duration 0.05 --out x.h5".split()
)
SENSED_APP = (*APP, "--observe", "sensors")
SENSED_EVALUATE = (*EVALUATE, "--observe", "sensors")
NOISE_BOUND = (
    "--sensor-noise must be between 0 and 100 (a std in the sensor's unit: m, rad, m/s, rad/s, "
    "m/s^2), got"
)
RATE_BOUND = "--sensor-rate-hz must be between 0.1 and 1000000 Hz, got"
DELAY_BOUND = "--sensor-delay-ms must be between 0 and 10000 ms, got"
NOT_A_SENSOR_VALUE = "--sensor-noise expects NUMBER or TYPE=NUMBER (e.g. framepos=30), got '=0.1'"
NO_ESTIMATOR = "unknown estimator ''; valid estimators are: ekf, legged, state, ukf"
HAVE_H5PY = importlib.util.find_spec("h5py") is not None
BAD_EVALUATE = tuple("bad" if arg == "cartpole" else arg for arg in EVALUATE)
BAD_BENCHMARK = tuple("bad" if arg == "cartpole" else arg for arg in BENCHMARK)
BAD_TUNE = tuple("bad" if arg == "cartpole" else arg for arg in TUNE)
USER_FAILED = "--debug shows the traceback"


@dataclass(frozen=True)
class Row:
    """One case: `python -m judo ARGS` (in the folder of FILES) exits `status` with `message` on
    stderr."""

    args: tuple[str, ...]
    status: int
    message: str
    one_line: bool = True  # False for a usage error, which prints the usage line first
    interrupt: bool = False  # send SIGINT once the command is at work

    @property
    def id(self) -> str:
        return " ".join(self.args)


def config(name: str) -> tuple[str, ...]:
    return ("--config", name)


TABLE = [
    # one config-file reader, for every command: refused before it is opened or parsed
    Row((*APP, *config("adir")), 2, "config file adir is a directory"),
    Row(
        (*APP, *config("binary.toml")), 2, "config file binary.toml is binary (it holds NUL bytes)"
    ),
    Row(
        (*APP, *config("latin1.toml")),
        2,
        "config file latin1.toml is not UTF-8 text (byte 11, line 1)",
    ),
    Row(
        (*APP, *config("big.toml")),
        2,
        "config file big.toml is 1100003 bytes; a config file is at most 1000000",
    ),
    Row(
        (*APP, *config("fifo")),
        2,
        "config file fifo is not a regular file (a FIFO, device or socket)",
    ),
    Row((*APP, *config("/dev/zero")), 2, "config file /dev/zero is not a regular file"),
    Row((*APP, *config("missing.toml")), 2, "config file not found: missing.toml"),
    Row((*APP, *config("")), 2, "--config needs the path of a TOML file, got an empty path"),
    Row(
        (*APP, *config("bigint.toml")),
        2,
        "CartpoleConfig.w_vertical expects a finite number, got 99999",
    ),
    Row(
        (*APP, *config("unknown_task.toml")),
        2,
        "[controller_config_overrides.no_such_task]: unknown task",
    ),
    Row((*EVALUATE, *config("fifo")), 2, "config file fifo is not a regular file"),
    Row((*EVALUATE, *config("adir")), 2, "config file adir is a directory"),
    Row((*EVALUATE, *config("")), 2, "--config needs the path of a TOML file"),
    Row((*BENCHMARK, *config("fifo")), 2, "config file fifo is not a regular file"),
    Row((*BENCHMARK, *config("/dev/zero")), 2, "config file /dev/zero is not a regular file"),
    Row((*TUNE, *config("fifo")), 2, "config file fifo is not a regular file"),
    Row((*TUNE, *config("binary.toml")), 2, "config file binary.toml is binary"),
    # user classes and rewards that raise: one line naming the class, file:line and the exception
    Row(
        ("--task", "bad", *APP, *config("init_fails.toml")),
        1,
        "RuntimeError: cannot build the task (raised in InitFails.__init__, ",
    ),
    Row(
        ("--task", "bad", *APP, *config("config_fails.toml")),
        1,
        "config init failed (raised in BadConfig.__post_init__",
    ),
    Row((*BAD_EVALUATE, *config("init_fails.toml")), 1, "(raised in InitFails.__init__, "),
    Row((*BAD_EVALUATE, *config("config_fails.toml")), 1, "(raised in BadConfig.__post_init__, "),
    Row(
        (*BAD_EVALUATE, *config("reward_fails.toml")),
        1,
        "ZeroDivisionError: reward blew up (raised in RewardFails.reward, ",
    ),
    Row((*BAD_EVALUATE, *config("reward_strings.toml")), 2, "RewardStrings.reward must return ("),
    Row((*BAD_BENCHMARK, *config("init_fails.toml")), 1, "(raised in InitFails.__init__, "),
    Row((*BAD_BENCHMARK, *config("reward_fails.toml")), 1, "(raised in RewardFails.reward, "),
    Row(  # the app logs each skipped cycle, then says why the run failed
        ("--headless", "--duration", "0.3", "--task", "bad", *config("reward_fails.toml")),
        1,
        "no plan ever succeeded in this run: planning cycle skipped: ZeroDivisionError "
        "in bad: reward blew up",
        one_line=False,
    ),
    Row((*BAD_BENCHMARK, *config("reward_strings.toml")), 2, "RewardStrings.reward must return"),
    Row((*BAD_TUNE, *config("init_fails.toml")), 2, "cannot build the task"),
    # sizes, latencies and durations beyond their bounds
    Row(
        (*EVALUATE, "--num-workers", "5000"),
        2,
        "--num-workers must be an integer from 1 to 1024, got 5000",
    ),
    Row((*EVALUATE, "--workers", "0"), 2, "--workers must be an integer from 1 to 1024, got 0"),
    Row(
        (*EVALUATE, "--workers", "5000"), 2, "--workers must be an integer from 1 to 1024, got 5000"
    ),
    Row(
        (*BENCHMARK, "--num-workers", "5000"),
        2,
        "--num-workers must be an integer from 1 to 1024, got 5000",
    ),
    Row((*TUNE, "--workers", "5000"), 2, "--workers must be an integer from 1 to 1024, got 5000"),
    # the defaults pass the check episode; every grid trial's w_vertical makes the reward raise
    Row(
        (
            *BAD_TUNE,
            *config("reward_fails_above.toml"),
            "--sampler",
            "grid",
            "--params",
            "task.w_vertical=1:2",
            "--workers",
            "1",
            "--latency-ms",
            "0",
        ),
        1,
        "every trial failed; the first reason: ValueError: w_vertical too low for this test",
        one_line=False,
    ),
    Row(
        (*BENCHMARK[:-4], "--samples", str(10**12)),
        2,
        "--samples must be an integer from 1 to 100000",
    ),
    Row(
        (*EVALUATE, "--latency-ms", "-1"), 2, "--latency-ms must be between 0 and 60000.0, got -1.0"
    ),
    Row((*TUNE, "--latency-ms", "-1"), 2, "--latency-ms must be between 0 and 60000.0, got -1.0"),
    Row(
        ("--headless", "--duration", "1e308"),
        2,
        "duration must be a positive, finite number of seconds of sim time, at most 1e+09",
    ),
    Row(
        (*TUNE[:-2], "--duration", "inf"),
        2,
        "--duration must be above 0 and at most 86400.0 s, got inf",
    ),
    Row(
        (*EVALUATE, "--first-seed", "-1"),
        2,
        f"--first-seed must be an integer from 0 to {2**31 - 1} (the last seed",
    ),
    Row(
        (*EVALUATE[:-4], "--seeds", "3", "--first-seed", str(2**31 - 2)),
        2,
        f"--first-seed must be an integer from 0 to {2**31 - 3} (the last seed, "
        "--first-seed + --seeds - 1, is at "
        f"most {2**31 - 1}), got {2**31 - 2}",
    ),
    Row(
        (*COLLECT, "--first-seed", str(2**31)),
        2,
        "(the last seed, --first-seed + --episodes - 1, is at most",
    ),
    Row(
        (*TUNE, "--first-seed", "-5"),
        2,
        "--first-seed must be an integer from 0 to 2147483647 (the last seed",
    ),
    Row(
        (*TUNE, "--params", "optimizer.sigma=0:inf"),
        2,
        "LOW and HIGH must be finite numbers of magnitude",
    ),
    Row(
        (*TUNE, "--params", "optimizer.sigma=0:" + "9" * 5000),
        2,
        "LOW and HIGH must be finite numbers",
    ),
    # output paths, checked before any work
    Row((*EVALUATE, "--json", "adir"), 2, "--json 'adir' is a folder; give a file path"),
    Row((*EVALUATE, "--plot", "a_file/plot.png"), 2, "--plot: "),
    Row((*BENCHMARK, "--json", "adir"), 2, "--json 'adir' is a folder"),
    Row((*TUNE, "--out", "a_file"), 2, "--out 'a_file' is a file; give a folder"),
    # access, usage and messages
    Row(("--host", "0.0.0.0", "--token", "", *APP), 2, "token must not be empty or blank"),
    Row(
        ("--task", "-x"),
        2,
        "python -m judo: error: argument --task: expected one argument",
        one_line=False,
    ),
    Row(("--task", "x" * 3000, *APP), 2, "unknown task 'xxxxxxxx"),
    # sensing and estimation
    Row(
        (*APP, "--estimator", "nope"),
        2,
        "unknown estimator 'nope'; valid estimators are: ekf, legged, state, ukf",
    ),
    Row(
        ("--task", "bad", *APP, *config("no_sensors.toml"), "--observe", "sensors"),
        2,
        "NoSensors declares no measured sensors; list the MJCF sensors a robot has in "
        "NoSensors.measured_sensors",
    ),
    Row(
        (*APP, "--observe", "sensors", "--sensor-rate-hz", "framepos=x"),
        2,
        "--sensor-rate-hz expects NUMBER or",
    ),
    Row(
        (*APP, "--observe", "sensors", "--sensor-noise", "bogus=0.1"),
        2,
        "sensor noise: 'bogus' is not a sensor type",
    ),
    Row((*SENSED_APP, "--sensor-delay-ms", "-5"), 2, f"{DELAY_BOUND} -5.0"),
    Row((*SENSED_APP, "--sensor-noise", "=0.1"), 2, NOT_A_SENSOR_VALUE),
    Row((*SENSED_APP, "--sensor-noise", "1e308"), 2, f"{NOISE_BOUND} 1e+308"),
    Row((*SENSED_APP, "--sensor-delay-ms", "1e12"), 2, f"{DELAY_BOUND} 1000000000000.0"),
    Row((*SENSED_APP, "--sensor-rate-hz", "1e-9"), 2, f"{RATE_BOUND} 1e-09"),
    Row(
        (*SENSED_APP, "--sensor-noise", "framepos=nan"),
        2,
        NOISE_BOUND.replace("noise", "noise framepos") + " nan",
    ),
    Row((*APP, "--estimator", ""), 2, NO_ESTIMATOR),
    Row((*SENSED_EVALUATE, "--sensor-noise", "=0.1"), 2, NOT_A_SENSOR_VALUE),
    Row((*SENSED_EVALUATE, "--sensor-noise", "1e308"), 2, f"{NOISE_BOUND} 1e+308"),
    Row((*SENSED_EVALUATE, "--sensor-delay-ms", "1e12"), 2, f"{DELAY_BOUND} 1000000000000.0"),
    Row((*SENSED_EVALUATE, "--sensor-rate-hz", "1e-9"), 2, f"{RATE_BOUND} 1e-09"),
    Row((*EVALUATE, "--estimator", ""), 2, NO_ESTIMATOR),
    Row(
        (*TUNE, "--observe", "sensors", "--sensor-delay-ms", "1e12"),
        2,
        f"{DELAY_BOUND} 1000000000000.0",
    ),
    Row((*COLLECT, "--observe", "sensors", "--sensor-rate-hz", "-1"), 2, f"{RATE_BOUND} -1.0"),
    Row((*COLLECT, "--observe", "sensors", "--sensor-noise", "inf"), 2, f"{NOISE_BOUND} inf"),
    Row(
        (*BENCHMARK, "--tasks"),
        2,
        "--tasks needs at least one name; leave --tasks out for all of them",
    ),
    Row(
        (*APP, "--sensor-noise", "0.1"),
        2,
        "--sensor-noise set the rehearsed sensors, which run only with --observe",
    ),
    Row(
        (*EVALUATE, "--estimator", "nope"),
        2,
        "unknown estimator 'nope'; valid estimators are: ekf, legged, state, ukf",
    ),
    Row(
        (*BAD_EVALUATE, *config("no_sensors.toml"), "--observe", "sensors"),
        2,
        "NoSensors declares no measured sensors; list the MJCF sensors a robot has in "
        "NoSensors.measured_sensors",
    ),
    Row(
        (*EVALUATE, "--observe", "sensors", "--estimator", "state"),
        2,
        "the 'state' estimator cannot run on this",
    ),
    Row(
        (*EVALUATE, "--observe", "sensors", "--sensor-rate-hz", "9", "--sensor-rate-hz", "a=x"),
        2,
        "--sensor-rate-hz expects",
    ),
    Row(
        (*TUNE, "--estimator", "nope"),
        2,
        "unknown estimator 'nope'; valid estimators are: ekf, legged, state, ukf",
    ),
    Row(
        (*TUNE, "--sensor-delay-ms", "10"),
        2,
        "--sensor-delay-ms set the rehearsed sensors, which run only with",
    ),
    Row(
        (*COLLECT, "--estimator", "nope"),
        2,
        "unknown estimator 'nope'; valid estimators are: ekf, legged, state, ukf",
    ),
    # HDF5 files (written by write_h5_files): another program's is never written into; a broken one
    # never played
    Row(
        (*COLLECT[:-1], "other.h5"),
        2,
        "other.h5 is an HDF5 file judo did not write (it holds images and no judo "
        "env_args); judo writes only into "
        "its own datasets: give another file",
    ),
    *(
        Row(("replay", f"{name}.h5"), 2, f"{name}.h5{message}")
        for name, message in [
            (
                "nan",
                ": data/demo_0/obs/qpos holds non-finite values (NaN or inf) in 1 of "
                "its 5 rows, the first row 2",
            ),
            (
                "narrow",
                ": data/demo_0/obs/qpos must have shape (S, 2) for cartpole's nq = 2, got (5, 1)",
            ),
            (
                "no_timestep",
                " is not a file of `python -m judo collect`: data's env_args has "
                "no entry 'plant_timestep'",
            ),
        ]
    ),
    Row(
        ("replay", "nan.h5", "--host", "0.0.0.0", "--token", ""),
        2,
        "token must not be empty or blank",
    ),
    # Ctrl-C
    Row(
        (*EVALUATE[:-2], "--duration", "3000", "--num-workers", "2"),
        130,
        "interrupted",
        interrupt=True,
    ),
    Row(
        (*BENCHMARK[:-4], "--samples", "100000", "--num-workers", "2"),
        130,
        "interrupted",
        interrupt=True,
    ),
]


def run_row(row: Row, folder: Path) -> tuple[int | None, str]:
    """The exit status (None: it hung) and stderr of `row` run in `folder`."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [SRC, os.environ.get("PYTHONPATH")])),
    }
    env["RAY_AUTH_MODE"] = "disabled"
    process = subprocess.Popen(
        [sys.executable, "-m", "judo", *row.args],
        cwd=folder,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    if row.interrupt:
        interrupt_at_work(process)
    try:
        _, err = process.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        process.kill()
        return None, process.communicate()[1]
    return process.returncode, err


def interrupt_at_work(process: subprocess.Popen) -> None:
    """SIGINT `process` once its 2 rollout threads run, so the signal reaches the work, not `import
    judo` (a Ctrl-C there is Python's own, before judo runs)."""
    deadline = time.monotonic() + TIMEOUT

    def threads() -> int:
        return len(os.listdir(f"/proc/{process.pid}/task"))

    while (
        "mujoco" not in Path(f"/proc/{process.pid}/maps").read_text()
        and time.monotonic() < deadline
    ):
        time.sleep(0.05)
    loaded = threads()  # numpy's and MuJoCo's own threads are up by now
    while threads() < loaded + 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    process.send_signal(signal.SIGINT)


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory) -> dict[str, tuple[int | None, str]]:
    """Every row's outcome, run a few at a time."""
    folder = tmp_path_factory.mktemp("cli_boundary")
    for name, content in FILES.items():
        (folder / name).write_bytes(content if isinstance(content, bytes) else content.encode())
    (folder / "adir").mkdir()
    os.mkfifo(folder / "fifo")
    if HAVE_H5PY:
        write_h5_files(folder)
    with ThreadPoolExecutor(4) as pool:
        return dict(
            zip(
                (row.id for row in TABLE),
                pool.map(lambda row: run_row(row, folder), TABLE),
                strict=True,
            )
        )


def write_h5_files(folder: Path) -> None:
    """other.h5, another program's HDF5 file, and cartpole replays in judo's layout that are broken:
    a NaN row in qpos (nan.h5), qpos one column short (narrow.h5), and no plant_timestep in env_args
    (no_timestep.h5)."""
    import h5py

    with h5py.File(folder / "other.h5", "w") as file:
        file["images"] = np.zeros((2, 3))
    qpos = np.zeros((5, 2))  # cartpole: nq = 2
    qpos[2] = np.nan
    env_args = {"type": "judo", "task": "cartpole", "optimizer": "ps", "plant_timestep": 0.01}
    for name, rows, args in [
        ("nan", qpos, env_args),
        ("narrow", np.zeros((5, 1)), env_args),
        ("no_timestep", np.zeros((5, 2)), {**env_args, "plant_timestep": None}),
    ]:
        with h5py.File(folder / f"{name}.h5", "w") as file:
            file.create_group("data").attrs["env_args"] = json.dumps(
                {k: v for k, v in args.items() if v is not None}
            )
            demo = file.create_group("data/demo_0")
            demo["obs/qpos"], demo["plan/times"] = rows, np.array([0.0, 0.02])
            demo.attrs.update({"seed": 0, "metrics": "{}", "success": False})


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="FIFOs, /dev/zero and /proc")
@pytest.mark.parametrize("row", TABLE, ids=lambda row: row.id[:80])
def test_every_bad_input_gets_one_line_and_its_exit_status(outcomes, row):
    if ".h5" in row.id and not HAVE_H5PY:
        pytest.skip("the HDF5 rows need h5py (the collect extra)")
    status, err = outcomes[row.id]
    assert status is not None, f"hung: {row.args}"
    assert "Traceback" not in err, err[-3000:]
    assert row.message in err, err[-3000:]
    assert status == row.status, err[-3000:]
    lines = err.strip().splitlines()
    if row.one_line:
        assert len(lines) == 1, err[-3000:]
    assert "__main__.py" not in err
    assert all(len(line) < 700 for line in lines)  # offending values are cut to 200 characters


def test_the_table_covers_every_command():
    named = ("evaluate", "benchmark", "tune", "collect", "replay")
    commands = {row.args[0] if row.args[0] in named else "app" for row in TABLE}
    assert commands == {"app", *named}
    assert len({row.id for row in TABLE}) == len(TABLE)  # ids are the outcome keys


@pytest.mark.slow
def test_debug_shows_the_users_own_traceback(tmp_path):
    for name in ("user_classes.py", "init_fails.toml"):
        (tmp_path / name).write_text(str(FILES[name]))
    status, err = run_row(
        Row((*BAD_EVALUATE, *config("init_fails.toml"), "--debug"), 1, ""), tmp_path
    )
    assert (
        status == 1 and "Traceback" in err and 'raise RuntimeError("cannot build the task")' in err
    )
