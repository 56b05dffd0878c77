"""The ROS 2 bridge across two processes on loopback: round trip, per-cycle overhead and closed-loop
quality.

- Round trip: a command written on /judo/commands, read by the plant process (`python -m judo plant
  --echo`), which writes it straight back; median and p99 of write -> echo read, ms (two DDS hops;
  one way is about half).
- Per-cycle overhead: the bridge's read_state + apply + step (its pacing sleep off) against
  MujocoSystem's read_state + apply in-process (without its physics step, which the robot does),
  microseconds.
- Closed-loop quality, cartpole with mppi, same seeds: the same ClosedLoop on the same wall clock,
  driving (a) judo's simulator in-process, stepped in wall time (it keeps running while the planner
  thinks, as a robot does), (b) the plant process over DDS, (c) the plant with --latency-ms 20
  --drop 0.1. balanced_fraction is cartpole's own metric (final 3 s), on the plant's true states in
  (a) and on the states the robot sent in (b, c).

    PYTHONPATH=src python benchmarks/ros2_bridge.py [--seeds 3] [--duration 10] [--latency-compensation]

Wall-clock closed loops on a shared, loaded machine are noisy: a planning cycle that a busy core
delays is a late plan on the robot. Needs pip install -e ".[ros2]".
"""  # noqa: E501

import os
import random
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro

import judo
from judo.core.configuration.registry import make_config
from judo.core.task import EpisodeLog
from judo.loop.closed_loop import ClosedLoop
from judo.loop.records import StepRecord
from judo.loop.system import MujocoSystem
from judo.optimizers.mppi import MPPIConfig
from judo.ros2 import link
from judo.ros2 import messages as msg
from judo.ros2.bridge import Ros2System
from judo.ros2.options import Ros2Options
from judo.tasks.cartpole import Cartpole

ROOT = Path(__file__).resolve().parents[1]


@dataclass
class Args:
    seeds: int = 3
    """Seeds of the closed-loop comparison (0, 1, ...)."""
    duration: float = 10.0
    """Wall seconds of each closed-loop episode."""
    round_trips: int = 300
    """Commands timed for the round trip."""
    cycles: int = 2000
    """Cycles timed for the per-cycle overhead."""
    latency_compensation: bool = False
    """Plan from the reading predicted to when the plan takes effect
    (ControllerConfig.latency_compensation)."""


class WallClockMujoco(MujocoSystem):
    """judo's simulator in-process, advanced in wall time: each `step` runs the physics steps due
    since the last one (the plant runs on while the planner thinks, as a robot does)."""

    def __init__(self, task) -> None:
        super().__init__(task)
        self._origin: float | None = None
        self._steps = 0

    def step(self) -> None:
        now = time.monotonic()
        if self._origin is None:
            self._origin = now
        self._steps += 1
        due = self._origin + self._steps * self.timestep
        if due > now:
            time.sleep(due - now)
        # catch up on a slow cycle
        while self._steps * self.timestep < time.monotonic() - self._origin:
            super().step()
            self._steps += 1
        super().step()


class Steps:
    """A recorder keeping every step's record."""

    def __init__(self) -> None:
        self.records: list[StepRecord] = []

    def on_plan(self, record) -> None:
        pass

    def on_step(self, record: StepRecord) -> None:
        self.records.append(record)


def start_plant(domain: int, seed: int, *flags: str) -> subprocess.Popen:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]),
    }
    proc = subprocess.Popen(
        [sys.executable, "-m", "judo", "plant", "--task", "cartpole", "--seed", str(seed)]
        + ["--ros2.domain-id", str(domain), *flags],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=env,
    )
    assert proc.stdout is not None and "publishing" in proc.stdout.readline()
    return proc


def stop(proc: subprocess.Popen) -> None:
    proc.terminate()
    proc.wait(timeout=10)


def controller(seed: int, latency_compensation: bool) -> judo.Controller:
    config = make_config(judo.ControllerConfig, "cartpole", "mppi")
    config.latency_compensation = latency_compensation
    return judo.make_controller(
        "cartpole",
        "mppi",
        controller_config=config,
        optimizer_config=make_config(MPPIConfig, "cartpole"),
        seed=seed,
    )


def balanced_fraction(records: list[StepRecord]) -> float:
    times = np.array([r.time for r in records])
    states = np.array([r.state for r in records])
    controls = np.array([r.action for r in records])
    log = EpisodeLog(
        times=times, states=states, controls=controls, sensors=np.zeros((len(records), 0))
    )
    return Cartpole().metrics(log)["balanced_fraction"]


def episode(system, seed: int, duration: float, latency_compensation: bool) -> float:
    steps = Steps()
    loop = ClosedLoop(
        controller(seed, latency_compensation), system, clock=time.monotonic, recorders=[steps]
    )
    end = time.monotonic() + duration
    while time.monotonic() < end:
        loop.step()
    return balanced_fraction(steps.records)


def round_trip(domain: int, count: int) -> np.ndarray:
    """(count,) seconds from writing a command to reading the plant's echo of it."""
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader

    proc = start_plant(domain, 0, "--echo")
    part = link.participant(domain)
    writer = DataWriter(
        part, link.topic(part, "/judo/commands", msg.Float64MultiArray), link.COMMAND_QOS
    )
    echo = DataReader(
        part, link.topic(part, "/judo/commands_echo", msg.Float64MultiArray), link.COMMAND_QOS
    )
    times = []
    try:
        time.sleep(1.0)  # discovery
        for k in range(count + 20):
            value = 1e-4 * (k + 1)  # within the cart's force range, unique per command
            sent = time.perf_counter()
            writer.write(link.commands(np.array([value])))
            got = None
            while got is None and time.perf_counter() - sent < 1.0:
                for m in link.take(echo, 8):
                    if m.data[0] == value:
                        got = time.perf_counter()
            if k >= 20 and got is not None:  # the first 20 warm up
                times.append(got - sent)
            time.sleep(0.01)
    finally:
        link.close_participant(part)
        stop(proc)
    return np.array(times)


def overhead(domain: int, cycles: int) -> tuple[float, float]:
    """(bridge read + apply + step, MujocoSystem read + apply) in microseconds per cycle,
    medians."""
    proc = start_plant(domain, 0)
    # no pacing sleep to speak of
    bridge = Ros2System(Cartpole(), Ros2Options(domain_id=domain, rate_hz=1e6))
    sim = MujocoSystem.from_task(Cartpole(), 0)
    action = np.array([0.1])
    try:
        wire, local = [], []
        for _ in range(cycles):
            start = time.perf_counter()
            bridge.read_state()
            bridge.apply(action)
            bridge.step()
            wire.append(time.perf_counter() - start)
            start = time.perf_counter()
            sim.read_state()
            sim.apply(action)
            local.append(time.perf_counter() - start)
    finally:
        bridge.close()
        stop(proc)
    return 1e6 * float(np.median(wire)), 1e6 * float(np.median(local))


def main() -> None:
    args = tyro.cli(Args)
    domain = random.SystemRandom().randint(100, 232)
    trips = 1e3 * round_trip(domain, args.round_trips)
    print(
        f"round trip (write -> plant reads -> echo read), {len(trips)} commands: "
        f"median {np.median(trips):.2f} ms, p99 {np.percentile(trips, 99):.2f} ms"
    )
    wire, local = overhead(domain, args.cycles)
    print(
        f"per cycle: bridge read+apply+step {wire:.0f} us, MujocoSystem read+apply {local:.0f} us, "
        f"the bridge adds {wire - local:.0f} us"
    )
    rows = {
        "in-process (wall clock)": [],
        "over DDS": [],
        "over DDS, --latency-ms 20 --drop 0.1": [],
    }
    for seed in range(args.seeds):
        rows["in-process (wall clock)"].append(
            episode(
                WallClockMujoco(MujocoSystem.from_task(Cartpole(), seed).task),
                seed,
                args.duration,
                args.latency_compensation,
            )
        )
        for name, flags in (
            ("over DDS", ()),
            ("over DDS, --latency-ms 20 --drop 0.1", ("--latency-ms", "20", "--drop", "0.1")),
        ):
            proc = start_plant(domain, seed, *flags)
            system = Ros2System(Cartpole(), Ros2Options(domain_id=domain))
            try:
                rows[name].append(episode(system, seed, args.duration, args.latency_compensation))
            finally:
                system.close()
                stop(proc)
    compensation = ", latency compensation" if args.latency_compensation else ""
    print(
        f"\ncartpole, mppi{compensation}, {args.seeds} seeds x {args.duration:g} s wall: "
        "balanced_fraction (final 3 s)"
    )
    print("| plant | mean | per seed |\n|---|---|---|")
    for name, values in rows.items():
        print(f"| {name} | {np.mean(values):.2f} | {' / '.join(f'{v:.2f}' for v in values)} |")


if __name__ == "__main__":
    main()
