"""Soak test: the GUI app with a headless-Chromium client for N minutes, then 200 task/optimizer
switches.

Every sample period (a minute by default) it prints the app process's resident memory and thread
count, and the control rate and real-time factor over that period. Then it switches task and
optimizer through the App API (the browser following each switch) and prints the growth. The goal:
memory growth under 5% from minute 2 to the end, and a flat thread count.

With --driver-faults SECONDS the app drives the task through a stand-in robot driver (the simulator
behind a System) that injects one fault every SECONDS for a second: a raising, NaN, wrong-shape or
frozen reading, a raising apply or step, or a call that blocks. The run then also prints how many
faults were injected, how many times the watchdog served the safe action, and how many calls
blocked; a user System cannot switch task, so the switch phase switches optimizer only.

PYTHONPATH=src python benchmarks/soak.py [--minutes 30] [--task cartpole] [--optimizer
mppi] [--switches 200] PYTHONPATH=src python benchmarks/soak.py --minutes 5 --driver-faults 10
"""

import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro

import judo
from judo.core.reading import SystemState
from judo.loop.system import MujocoSystem, System
from judo.runtime.app import App

SWITCH_CYCLE = (("cartpole", "mppi"), ("cartpole", "cem"), ("acrobot", "cem"), ("acrobot", "mppi"))
"""(task, optimizer) pairs the switch phase goes round: two optimizer switches and two task
switches."""


@dataclass
class Args:
    """How long to soak and how hard to switch."""

    minutes: float = 30.0
    """Length of the soak with the browser connected, in minutes."""
    task: str = "cartpole"
    """Task to run during the soak, by registered name."""
    optimizer: str = "mppi"
    """Optimizer to run during the soak, by registered name."""
    switches: int = 200
    """Task and optimizer switches made through the App API after the soak (0 skips the phase)."""
    sample_seconds: float = 60.0
    """Seconds between printed samples."""
    chromium: Path = Path("/usr/bin/chromium")
    """The Chromium binary playwright drives (never downloaded)."""
    driver_faults: float = 0.0
    """Inject one driver fault every this many seconds, for a second each (0: a fault-free
    simulator)."""


DRIVER_FAULTS = (
    "raising reading",
    "NaN reading",
    "wrong-shape reading",
    "frozen reading",
    "raising apply",
    "raising step",
    "blocking step",
)
"""The faults the stand-in driver injects in turn."""


class FaultyDriver(System):
    """The task's simulator behind a System whose calls fail in turn: one fault every `every` s, for
    1 s."""

    def __init__(self, task: str, every: float) -> None:
        with judo.make_controller(task, "ps", seed=0) as controller:
            self.plant = MujocoSystem.from_task(controller.task, seed=0)
        self.timestep, self.every, self.start = self.plant.timestep, every, time.monotonic()
        self.injected: dict[str, int] = {}
        self._frozen: SystemState | None = None
        self._lock = threading.Lock()

    def fault(self) -> str | None:
        """The fault in force now, counting each one once."""
        elapsed = time.monotonic() - self.start
        index = int(elapsed // self.every)
        if index == 0 or elapsed - index * self.every > 1.0:
            self._frozen = None
            return None
        name = DRIVER_FAULTS[(index - 1) % len(DRIVER_FAULTS)]
        with self._lock:
            key = f"{index}:{name}"
            if key not in self.injected:
                self.injected[key] = 1
        return name

    def reset(self) -> None:
        self.plant.reset()

    def read_state(self) -> SystemState:
        reading, fault = self.plant.read_state(), self.fault()
        if fault == "raising reading":
            raise OSError("encoder bus timeout")
        if fault == "NaN reading":
            reading.state[0] = np.nan
        elif fault == "wrong-shape reading":
            reading.state = reading.state[:-1]
        elif fault == "frozen reading":
            self._frozen = self._frozen or reading
            return self._frozen
        return reading

    def apply(self, action: np.ndarray) -> None:
        if self.fault() == "raising apply":
            raise OSError("drive fault")
        self.plant.apply(action)

    def step(self) -> None:
        fault = self.fault()
        if fault == "raising step":
            raise OSError("fieldbus frame lost")
        if fault == "blocking step":
            time.sleep(1.0)
        self.plant.step()


def process_status() -> tuple[float, int]:
    """(resident memory in MB, thread count) of this process, from /proc/self/status (Linux)."""
    fields = dict(line.split(":", 1) for line in Path("/proc/self/status").read_text().splitlines())
    return int(fields["VmRSS"].split()[0]) / 1024, int(fields["Threads"])


def say(text: str) -> None:
    print(text, flush=True)


def soak(app: App, page, args: Args) -> list[tuple[float, float, int]]:
    """Sample every `sample_seconds` for `minutes`; returns (minute, rss MB, threads) per sample."""
    samples = []
    start = time.perf_counter()
    last = (start, app.stats.num_plans(), app.stats.sim_time())
    say(f"{'minute':>7} {'rss MB':>8} {'threads':>8} {'control Hz':>11} {'RTF':>6}")
    while (now := time.perf_counter()) - start < 60 * args.minutes:
        # keeps the page alive
        page.wait_for_timeout(1000 * min(args.sample_seconds, start + 60 * args.minutes - now))
        now, plans, sim_time = time.perf_counter(), app.stats.num_plans(), app.stats.sim_time()
        rss, threads = process_status()
        rate = (plans - last[1]) / (now - last[0])
        rtf = (sim_time - last[2]) / (now - last[0])
        last = (now, plans, sim_time)
        minute = (now - start) / 60
        samples.append((minute, rss, threads))
        say(f"{minute:7.2f} {rss:8.1f} {threads:8d} {rate:11.1f} {rtf:6.3f}")
        if not app.running:
            raise SystemExit("the app stopped during the soak")
    return samples


def switch_phase(app: App, args: Args) -> None:
    """Switch `args.switches` times round SWITCH_CYCLE, waiting for the GUI to show each session."""
    rss_before, threads_before = process_status()
    warm_rss = rss_before
    say(f"switch phase: {args.switches} switches through the App API, GUI following each")
    for k in range(args.switches):
        session = app.session
        task, optimizer = SWITCH_CYCLE[k % len(SWITCH_CYCLE)]
        if (task, optimizer) == (session.task_name, session.optimizer_name):
            task, optimizer = SWITCH_CYCLE[(k + 1) % len(SWITCH_CYCLE)]
        if args.driver_faults:  # a user System is one task: switch optimizer only
            task = session.task_name
            optimizer = "cem" if session.optimizer_name != "cem" else "mppi"
        generation = session.generation
        if task != session.task_name:
            app.commands.switch_task(task)
        if optimizer != session.optimizer_name:
            app.commands.switch_optimizer(optimizer)  # queued with the task switch: one new session
        deadline = time.monotonic() + 30
        while app.gui.shown_generation <= generation:
            if time.monotonic() > deadline:
                raise SystemExit(
                    f"switch {k + 1} to {task}/{optimizer} did not show in the GUI within 30 s"
                )
            time.sleep(0.01)
        # every model has been loaded once: growth from here on is a leak
        if k + 1 == len(SWITCH_CYCLE):
            warm_rss = process_status()[0]
        if (k + 1) % 50 == 0 or k + 1 == args.switches:
            rss, threads = process_status()
            say(
                f"  {k + 1:4d} switches: rss {rss:.1f} MB ({rss - rss_before:+.1f}), threads "
                f"{threads}"
            )
    rss, threads = process_status()
    say(
        f"switch phase: rss {rss_before:.1f} -> {rss:.1f} MB "
        f"({100 * (rss - rss_before) / rss_before:+.1f}%), "
        f"threads {threads_before} -> {threads} over {args.switches} switches"
    )
    if args.switches > len(SWITCH_CYCLE):
        say(
            f"switch phase after the first {len(SWITCH_CYCLE)} (each model loaded once): rss "
            f"{warm_rss:.1f} -> "
            f"{rss:.1f} MB ({100 * (rss - warm_rss) / warm_rss:+.1f}%)"
        )


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    from playwright.sync_api import sync_playwright

    driver = FaultyDriver(args.task, args.driver_faults) if args.driver_faults else None
    app = App(args.task, args.optimizer, port=0, seed=0, system=driver)
    app.start()
    say(f"soak: {args.task} with {args.optimizer} for {args.minutes:g} min, GUI at {app.gui.url}")
    try:
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=str(args.chromium), headless=True)
            page = browser.new_page()
            page.goto(app.gui.url)
            page.get_by_text("Controller", exact=True).wait_for(timeout=120_000)
            say("browser connected")
            samples = soak(app, page, args)
            baseline = next((s for s in samples if s[0] >= 2.0 - 1e-6), samples[0])
            minute, rss, _ = samples[-1]
            threads = [s[2] for s in samples]
            say(
                f"soak: rss {baseline[1]:.1f} MB at minute {baseline[0]:.2f} -> {rss:.1f} MB "
                f"at minute {minute:.2f} "
                f"({100 * (rss - baseline[1]) / baseline[1]:+.1f}%), threads "
                f"{min(threads)}..{max(threads)}"
            )
            if args.switches:
                switch_phase(app, args)
            browser.close()
    finally:
        app.stop()
    say(str(app.summary()))
    if driver is not None:
        trips = app.session.closed_loop.watchdog.trips
        say(
            f"driver faults: {len(driver.injected)} injected ({', '.join(DRIVER_FAULTS)} in "
            "turn); the watchdog "
            f"served the safe action {trips} times in the last session; app still running at "
            "the end: "
            f"{'no (stopped by the soak)' if not app.running else 'yes'}"
        )


if __name__ == "__main__":
    sys.exit(main())
