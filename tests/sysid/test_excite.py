"""python -m judo excite's pacing and its boundary: a user's System is stepped once per timestep of wall clock (the
app's plant clock), and every input it cannot run is refused in one line, exit 2, before anything is
written."""  # noqa: E501

import time

import numpy as np
import pytest

from judo.core.reading import SystemState
from judo.core.task import Task
from judo.loop.system import System
from judo.sysid.excite import MAX_STEPS
from judo.sysid.excite import main as excite_main

pytest.importorskip("h5py")


class TimedProbe(System):
    """A System whose step() returns at once and records the wall time (time.perf_counter()) of each
    call."""

    TIMESTEP = 0.01
    calls: list[float] = []

    def __init__(self, task: Task) -> None:
        self.model, self.timestep, self.time = task.model, self.TIMESTEP, 0.0
        type(self).calls = []

    def reset(self) -> None:
        self.time = 0.0

    def read_state(self) -> SystemState:
        return SystemState(np.concatenate([self.model.qpos0, np.zeros(self.model.nv)]), self.time)

    def apply(self, action: np.ndarray) -> None:
        pass

    def step(self) -> None:
        type(self).calls.append(time.perf_counter())
        self.time += self.timestep


class ZeroStepProbe(TimedProbe):
    TIMESTEP = 0.0


class FineStepProbe(TimedProbe):
    TIMESTEP = 1e-5


def test_a_users_system_is_stepped_once_per_timestep_of_wall_clock(tmp_path, capsys):
    """100 steps of 0.01 s: step k is called no earlier than k timesteps after the first (the
    clock's origin), and on average one timestep apart (the upper bound generous for a loaded
    machine, whose delays only add)."""
    argv = ["--task", "cartpole", "--system", f"{__name__}:TimedProbe", "--duration", "1"]
    assert excite_main([*argv, "--out", str(tmp_path / "paced.h5")]) == 0
    assert "wrote 100 steps of excitation of cartpole through TimedProbe" in capsys.readouterr().out
    calls = np.array(TimedProbe.calls)
    assert len(calls) == 100
    since_first = calls - calls[0]
    early = since_first - np.arange(100) * TimedProbe.TIMESTEP
    assert early.min() > -1e-3, f"step {early.argmin()} came {-early.min():.4f} s before it was due"
    mean = np.diff(calls).mean()
    assert 0.9 * TimedProbe.TIMESTEP <= mean <= 3 * TimedProbe.TIMESTEP, (
        f"mean spacing {mean:.5f} s"
    )


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["--duration", "1e9"],
            "--duration must be in (0, 3600] s (at most an hour of excitation), got 1000000000.0",
        ),
        (
            ["--duration", "nan"],
            "--duration must be in (0, 3600] s (at most an hour of excitation), got nan",
        ),
        (
            ["--duration", "0.001"],
            "--duration 0.001 s is less than one step of MujocoSystem (0.01 s); give at least",
        ),
        (["--seed", "-1"], "--seed must be >= 0, got -1"),
        (
            ["--bandwidth", "1000"],
            "--bandwidth must be at most the plant's Nyquist frequency, 50 Hz (a step of 0.01 s)",
        ),
        (
            ["--system", f"{__name__}:ZeroStepProbe"],
            "ZeroStepProbe.timestep must be the seconds one step() advances (a "
            "number > 0), got 0.0",
        ),
        (
            ["--system", f"{__name__}:FineStepProbe", "--duration", "10"],
            "--duration 10 s is 1000000 steps of 1e-05 s; excite logs at most "
            f"{MAX_STEPS} steps (4 s at this",
        ),
    ],
    ids=[
        "huge-duration",
        "nan-duration",
        "under-one-step",
        "negative-seed",
        "above-nyquist",
        "zero-timestep",
        "too-many-steps",
    ],  # fmt: skip
)
def test_an_input_excite_cannot_run_is_one_line_exit_2_and_writes_nothing(
    tmp_path, capsys, argv, message
):
    out = tmp_path / "never.h5"
    with pytest.raises(SystemExit) as caught:
        excite_main(["--task", "cartpole", *argv, "--out", str(out)])
    err = capsys.readouterr().err
    assert caught.value.code == 2 and err.count("\n") == 1 and message in err, err
    assert not out.exists()
