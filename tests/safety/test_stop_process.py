"""The latched stop in a real `python -m judo --headless` process: SIGUSR1 latches it, the exit
summary says when it took effect, and the next start of the app begins latched and says how to clear
it."""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from judo.safety.stop import STOP_FILE_ENV

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


class Judo:
    """`python -m judo ARGS` in the repository on the stop file `stop_file`, its output (stdout and
    stderr) kept."""

    def __init__(self, args: list[str], stop_file: Path) -> None:
        env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]),
        }
        env[STOP_FILE_ENV] = str(stop_file)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "judo", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=env,
            cwd=ROOT,
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)

    def output(self) -> str:
        return "".join(self.lines)

    def wait_for(self, text: str, timeout: float = 120.0) -> None:
        deadline = time.monotonic() + timeout
        while text not in self.output():
            if self.proc.poll() is not None and not self._reader.is_alive():
                pytest.fail(
                    f"judo exited ({self.proc.returncode}) before saying {text!r}:\n{self.output()}"
                )
            if time.monotonic() > deadline:
                pytest.fail(f"judo did not say {text!r} within {timeout} s:\n{self.output()}")
            time.sleep(0.05)

    def finish(self, timeout: float = 180.0) -> str:
        """Its whole output once it exited by itself (its --duration reached)."""
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            pytest.fail(f"judo did not end within {timeout} s:\n{self.output()}")
        self._reader.join(10)
        return self.output()


def test_sigusr1_latches_a_headless_app_and_the_next_start_begins_latched(tmp_path):
    stop_file = tmp_path / "stop.json"
    first = Judo(["--task", "cartpole", "--headless", "--seed", "0"], stop_file)
    first.wait_for("running cartpole with mppi")
    first.proc.send_signal(signal.SIGUSR1)
    first.wait_for("stop latched by SIGUSR1")
    first.wait_for("stop in effect after")  # the plant was served the safe action
    assert stop_file.exists()
    first.proc.send_signal(signal.SIGINT)
    output = first.finish()
    # 1 only where the interrupt came before the first plan on a loaded machine (a headless run says
    # so)
    assert first.proc.returncode == 0 or "no plan ever succeeded" in output, output
    summary = output[output.index("task: cartpole") :]
    assert "stop: latched by SIGUSR1 at" in summary and "(in effect after" in summary, summary
    assert "still latched at exit" in summary, summary
    print("SIGUSR1 -> the safe action served:", summary.split("(in effect after ")[1].split(")")[0])

    # --stop-file names the file over $JUDO_STOP_FILE
    args = [
        "--task",
        "cartpole",
        "--headless",
        "--seed",
        "0",
        "--duration",
        "0.2",
        "--stop-file",
        str(stop_file),
    ]
    second = Judo(args, tmp_path / "another.json")
    output = second.finish()
    assert second.proc.returncode == 0 or "no plan ever succeeded" in output, output
    assert "the stop is latched, latched by SIGUSR1 (from the state file" in output, output
    assert "Clear stop" in output and "/judo/estop" in output
    assert "still latched at exit" in output and stop_file.exists()
