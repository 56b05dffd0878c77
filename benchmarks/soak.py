"""Soak test: the GUI app with a headless-Chromium client for N minutes, then 200 task/optimizer switches.

Every sample period (a minute by default) it prints the app process's resident memory and thread
count, and the control rate and real-time factor over that period. Then it switches task and
optimizer through the App API (the browser following each switch) and prints the growth. The goal:
memory growth under 5% from minute 2 to the end, and a flat thread count.

PYTHONPATH=src python benchmarks/soak.py [--minutes 30] [--task cartpole] [--optimizer mppi] [--switches 200]
"""

import sys
import time
from dataclasses import dataclass
from pathlib import Path

import tyro

from judo.runtime.app import App

SWITCH_CYCLE = (("cartpole", "mppi"), ("cartpole", "cem"), ("acrobot", "cem"), ("acrobot", "mppi"))
"""(task, optimizer) pairs the switch phase goes round: two optimizer switches and two task switches."""


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
        page.wait_for_timeout(1000 * min(args.sample_seconds, start + 60 * args.minutes - now))  # keeps the page alive
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
        generation = session.generation
        if task != session.task_name:
            app.switch_task(task)
        if optimizer != session.optimizer_name:
            app.switch_optimizer(optimizer)  # queued with the task switch: one new session
        deadline = time.monotonic() + 30
        while app.gui.shown_generation <= generation:
            if time.monotonic() > deadline:
                raise SystemExit(f"switch {k + 1} to {task}/{optimizer} did not show in the GUI within 30 s")
            time.sleep(0.01)
        if k + 1 == len(SWITCH_CYCLE):  # every model has been loaded once: growth from here on is a leak
            warm_rss = process_status()[0]
        if (k + 1) % 50 == 0 or k + 1 == args.switches:
            rss, threads = process_status()
            say(f"  {k + 1:4d} switches: rss {rss:.1f} MB ({rss - rss_before:+.1f}), threads {threads}")
    rss, threads = process_status()
    say(
        f"switch phase: rss {rss_before:.1f} -> {rss:.1f} MB ({100 * (rss - rss_before) / rss_before:+.1f}%), "
        f"threads {threads_before} -> {threads} over {args.switches} switches"
    )
    if args.switches > len(SWITCH_CYCLE):
        say(
            f"switch phase after the first {len(SWITCH_CYCLE)} (each model loaded once): rss {warm_rss:.1f} -> "
            f"{rss:.1f} MB ({100 * (rss - warm_rss) / warm_rss:+.1f}%)"
        )


def main() -> None:
    args = tyro.cli(Args, description=__doc__)
    from playwright.sync_api import sync_playwright

    app = App(args.task, args.optimizer, port=0, seed=0)
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
                f"soak: rss {baseline[1]:.1f} MB at minute {baseline[0]:.2f} -> {rss:.1f} MB at minute {minute:.2f} "
                f"({100 * (rss - baseline[1]) / baseline[1]:+.1f}%), threads {min(threads)}..{max(threads)}"
            )
            if args.switches:
                switch_phase(app, args)
            browser.close()
    finally:
        app.stop()
    say(str(app.summary()))


if __name__ == "__main__":
    sys.exit(main())
