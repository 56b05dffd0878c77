"""`python -m judo` stops on SIGINT and SIGTERM within 2 s, exit status 0, no traceback, no port
left listening: headless, with the GUI, and with a client connected to the GUI. A GUI that cannot
start ends the run at once with a message and a non-zero status."""

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import viser
from websockets.sync.client import connect

import judo.__main__

SRC = str(Path(judo.__main__.__file__).parents[1])
STOP_BUDGET = 2.0
"""Seconds from the signal to the process's exit."""


class JudoProcess:
    """`python -m judo ARGS` in a subprocess, its stderr collected line by line."""

    def __init__(self, *args: str) -> None:
        env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join(filter(None, [SRC, os.environ.get("PYTHONPATH")])),
        }
        small = ["--controller.horizon", "0.3", "--optimizer-config.num-rollouts", "16"]
        self.process = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "judo",
                "--task",
                "cartpole",
                "--optimizer",
                "ps",
                *small,
                *args,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stderr is not None
        for line in self.process.stderr:
            self.lines.append(line)

    @property
    def stderr(self) -> str:
        return "".join(self.lines)

    def wait_for(self, text: str, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        while text not in self.stderr:
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.process.kill()
                pytest.fail(f"never printed {text!r}; stderr:\n{self.stderr}")
            time.sleep(0.05)

    def stop_with(self, sig: signal.Signals) -> tuple[int, float]:
        """Send `sig`; the exit status and the seconds the process took to end."""
        start = time.monotonic()
        self.process.send_signal(sig)
        try:
            status = self.process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.process.kill()
            pytest.fail(f"{sig.name} did not stop the app in 30 s; stderr:\n{self.stderr}")
        elapsed = time.monotonic() - start
        self._reader.join(5)
        return status, elapsed


def listening(port: int) -> bool:
    with socket.socket() as sock:
        return sock.connect_ex(("127.0.0.1", port)) == 0


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_stops_the_headless_app_quickly_and_cleanly(sig):
    app = JudoProcess("--headless")
    app.wait_for("running cartpole with ps")
    time.sleep(0.5)
    status, elapsed = app.stop_with(sig)
    assert status == 0, app.stderr
    assert elapsed < STOP_BUDGET
    assert "Traceback" not in app.stderr


@pytest.mark.parametrize("client", [False, True], ids=["no client", "client connected"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_stops_the_gui_app_quickly_and_cleanly(sig, client, port):
    app = JudoProcess("--port", str(port))
    app.wait_for("running cartpole with ps")
    websocket = None
    if client:  # a client speaking viser's protocol, as the browser does
        websocket = connect(
            f"ws://127.0.0.1:{port}",
            subprotocols=[f"viser-v{viser.__version__}"],
            origin=f"http://127.0.0.1:{port}",
        )
        websocket.recv(timeout=10)  # the scene and panels start arriving
    status, elapsed = app.stop_with(sig)
    if websocket is not None:
        websocket.close()
    assert status == 0, app.stderr
    assert elapsed < STOP_BUDGET
    assert "Traceback" not in app.stderr and "Error" not in app.stderr, app.stderr
    assert not listening(port)


@pytest.mark.browser
def test_sigint_with_a_browser_connected_stops_cleanly(panel_page, port, pause_scene):
    app = JudoProcess("--port", str(port))
    app.wait_for("running cartpole with ps")
    page = panel_page()
    try:
        page.goto(f"http://127.0.0.1:{port}")
        page.get_by_text("Controller", exact=True).wait_for(timeout=60_000)
        pause_scene(page)
        status, elapsed = app.stop_with(signal.SIGINT)
    finally:
        page.close()
    assert status == 0 and elapsed < STOP_BUDGET
    assert "Traceback" not in app.stderr, app.stderr
    assert not listening(port)


@pytest.mark.parametrize(
    ("args", "status", "message"),
    [
        (
            ["--port", "99999"],
            2,
            "port must be an integer in 0..65535 (0 picks a free port), got 99999",
        ),
        (["--port", "-1"], 2, "port must be an integer in 0..65535 (0 picks a free port), got -1"),
        (
            ["--host", "999.1.1.1"],
            1,
            "cannot listen on '999.1.1.1': not a valid IPv4 address; use 127.0.0.1",
        ),
        (["--host", "10.255.255.1"], 1, "cannot listen on '10.255.255.1' (10.255.255.1): "),
    ],
)
def test_a_gui_that_cannot_start_ends_the_run_with_a_message(args, status, message):
    app = JudoProcess(*args)
    try:
        assert app.process.wait(timeout=30) == status
    except subprocess.TimeoutExpired:
        app.process.kill()
        pytest.fail(f"{args} hung; stderr:\n{app.stderr}")
    app._reader.join(5)
    assert f"python -m judo: {message}" in app.stderr
    assert "Traceback" not in app.stderr
