"""`python -m judo replay FILE.h5 [--demo N]`: play a collect file's episodes back in the GUI's 3-D
scene.

`python -m judo replay LOG.mcap [--task T]` plays a ROS 2 bridge's log (`--record`,
judo.ros2.mcap_read) the same way: one episode, its rows at the robot's JointState stamps.

Nothing is re-simulated: each frame poses the task's plant model at a recorded qpos (and mocap
positions), so a replay is exactly what happened. Where the file
has `plan/traces` (collect --traces, GUI recordings), each frame also draws the traces of the latest
plan made by its time, with the live GUI's own drawing (`SceneView.set_traces`). The page has a demo
dropdown, play/pause, a time scrubber, a speed control and the demo's metrics.
"""

import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import numpy as np
import tyro

from judo.cli_shared import apply_config_file, fail
from judo.core.configuration.config import require_between
from judo.core.errors import JudoError
from judo.core.reading import TIME_TOLERANCE
from judo.recording.dataset import DatasetError, demo_name
from judo.runtime.gui.replay_episodes import check_demos, read_episodes, read_traces, unpadded

FRAME_S = 1 / 30
"""Seconds between frames while playing."""


@dataclass
class ReplayArgs:
    """Arguments of `python -m judo replay`."""

    file: tyro.conf.Positional[Path]
    """The HDF5 file `python -m judo collect` (or the GUI's recorder) wrote, or a ROS 2 bridge's
    MCAP log."""
    task: Annotated[
        str | None, tyro.conf.arg(metavar="NAME", help_behavior_hint="(default: the log's)")
    ] = None
    """The task of an MCAP log that does not name it (the bridge's logs do; `ros2 bag record`'s do
    not)."""
    demo: Annotated[
        int | None, tyro.conf.arg(metavar="SEED", help_behavior_hint="(default: the first)")
    ] = None
    """Seed of the demo shown first."""
    config: Annotated[
        Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")
    ] = None
    """TOML file registering the file's task, when it is a task of your own."""
    host: str = "127.0.0.1"
    """Address the GUI listens on: this machine only by default. 0.0.0.0 (every interface) shows the
    recording to the network, behind a token, under the app's access rules (docs/gui.md)."""
    port: int = 8080
    """Port of the GUI (the next free one if taken)."""
    token: str | None = None
    """Secret the GUI's URL must carry (http://HOST:PORT/TOKEN); generated when --host is not a
    loopback address."""
    speed: float = 1.0
    """Playback speed at the start (sim seconds per second; the page's speed slider changes it)."""


class Replay:
    """A GUI playing the demos of `path` back; `start` serves it, `stop` ends it.

    Attributes:
        demo: the demo shown; index: its row shown (0..S-1); playing: whether time runs.
        scene: the SceneView posed from the recorded rows.
        token: the secret the page's URL carries (`check_token`: given, or generated beyond
            loopback), or None.
    """

    def __init__(
        self,
        path: Path,
        demo: int | None = None,
        host: str = "127.0.0.1",
        port: int = 8080,
        speed: float = 1.0,
        token: str | None = None,
        task: str | None = None,
    ) -> None:
        from judo.core.configuration.registry import make_task
        from judo.runtime.address import check_port, check_token

        check_port(port)
        # the app's rules: generated beyond loopback, never empty
        self.token = check_token(token, host)
        require_between("--speed", speed, 0.1, 4.0)
        self.env_args, self.demos = read_episodes(path, task)
        if demo is not None and demo not in self.demos:
            raise DatasetError(
                f"{path} has no demo of seed {demo}; its seeds are: "
                f"{', '.join(map(str, self.demos))}"
            )
        self.demo = self.demos[demo if demo is not None else next(iter(self.demos))]
        self.model = make_task(self.env_args["task"]).sim_model
        check_demos(path, self.demos, self.model, self.env_args["task"])
        self.path, self.host, self.port = path, host, port
        self.index, self.playing, self.speed = 0, False, float(speed)
        # (U, ...) the shown demo's plan traces, where the file has them
        self.traces: np.ndarray | None = None
        self.plan_shown = -1  # the plan whose traces are drawn (-1: none)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None  # the playback thread, from start()
        # held while a demo is chosen or a row is shown: hold it to read a whole frame
        self.lock = threading.Lock()

    def start(self) -> None:
        """Start the server, draw the first row of the demo and the widgets, and the playback
        thread."""
        from judo.runtime.gui.scene import SceneView
        from judo.runtime.gui.server import gui_url, start_server

        self.server = start_server(
            self.host, self.port, token=self.token, share=False, label="judo replay"
        )
        self.url = gui_url(self.server, self.token)
        self.scene = SceneView(self.server.scene, self.model)
        gui = self.server.gui
        gui.main_panel.dock_right()  # beside the view the camera frames, as in the app
        names = [demo_name(seed) for seed in self.demos]
        self.demo_dropdown = gui.add_dropdown(
            "demo", names, initial_value=demo_name(self.demo.seed)
        )
        self.play_button = gui.add_button("Play")
        self.time_slider = gui.add_slider("time (s)", 0.0, self._duration(), self._dt(), 0.0)
        self.speed_slider = gui.add_slider("speed", 0.1, 4.0, 0.1, self.speed)
        self.readout = gui.add_markdown("")
        self.demo_dropdown.on_update(
            lambda _: self.select(int(self.demo_dropdown.value.removeprefix("demo_")))
        )
        self.play_button.on_click(lambda _: self.set_playing(not self.playing))
        self.time_slider.on_update(lambda _: self.show(self._row(self.time_slider.value)))
        self.speed_slider.on_update(
            lambda _: setattr(self, "speed", float(self.speed_slider.value))
        )
        self.select(self.demo.seed)
        position, look_at = self.scene.camera_pose()
        self.server.initial_camera.position, self.server.initial_camera.look_at = position, look_at
        self._thread = threading.Thread(target=self._play, name="judo-replay", daemon=True)
        self._thread.start()

    def select(self, seed: int) -> None:
        """Show demo `seed` from its first row, with its metrics."""
        with self.lock:
            self.demo = self.demos[seed]
            self.traces = read_traces(self.path, seed) if self.demo.has_traces else None
            self.plan_shown = -1
            self.scene.set_traces(np.zeros((0, 0, 0, 3)))
        self.time_slider.max = self._duration()
        metrics = ", ".join(f"{name} {value:.3g}" for name, value in self.demo.metrics.items())
        verdict = (
            ""
            if self.demo.success is None
            else ", success"
            if self.demo.success
            else (", no success")
        )
        self.readout.content = (
            f"**{self.env_args['task']} x {self.env_args['optimizer']}**, seed "
            f"{seed}{verdict}  \n{metrics}"
        )
        self.seek(0)

    def set_playing(self, playing: bool) -> None:
        """Play or pause; playing from the last row starts over."""
        if playing and self.index >= len(self.demo.qpos) - 1:
            self.seek(0)
        self.playing = playing
        self.play_button.label = "Pause" if playing else "Play"

    def seek(self, index: int) -> None:
        """Show row `index` and move the scrubber there."""
        self.show(index)
        self.time_slider.value = float(self.demo.times[self.index])

    def show(self, index: int) -> None:
        """Pose the scene at row `index` (clamped) of the demo shown, with the traces of the latest
        plan made by its time."""
        with self.lock:
            demo = self.demo
            self.index = int(np.clip(index, 0, len(demo.qpos) - 1))
            metadata = {} if demo.mocap_pos is None else {"mocap_pos": demo.mocap_pos[self.index]}
            self.scene.update(demo.qpos[self.index], metadata)
            if self.traces is not None:
                plan = (
                    int(
                        np.searchsorted(
                            demo.plan_times, demo.times[self.index] + TIME_TOLERANCE, side="right"
                        )
                    )
                    - 1
                )
                if plan != self.plan_shown:
                    self.plan_shown = plan
                    self.scene.set_traces(
                        unpadded(self.traces[plan]) if plan >= 0 else np.zeros((0, 0, 0, 3))
                    )

    def stop(self) -> None:
        """Stop playing and the server."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        if hasattr(self, "server"):
            self.server.stop()

    def _play(self) -> None:
        last = time.perf_counter()
        # sim seconds shown while playing, kept unrounded so that slow speeds still advance
        clock = 0.0
        while not self._stop.wait(FRAME_S):
            now = time.perf_counter()
            if not self.playing:
                clock = float(self.demo.times[self.index])
            else:
                clock += (now - last) * self.speed
                row = self._row(clock)
                self.seek(row)
                if row >= len(self.demo.qpos) - 1:
                    self.set_playing(False)
            last = now

    def _dt(self) -> float:
        return float(self.env_args["plant_timestep"])

    def _duration(self) -> float:
        return float(self.demo.times[-1])

    def _row(self, seconds: float) -> int:
        """The row whose time is nearest `seconds` (the earlier of two as near)."""
        times = self.demo.times
        row = int(np.searchsorted(times, seconds))
        if row == len(times) or (row > 0 and seconds - times[row - 1] <= times[row] - seconds):
            row -= 1
        return row


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo replay` on `argv` (sys.argv[1:] when None) until Ctrl-C; exits 2 on bad
    arguments."""
    args = tyro.cli(ReplayArgs, args=argv, prog="python -m judo replay", description=__doc__)
    try:
        apply_config_file(args.config)
        replay = Replay(
            args.file, args.demo, args.host, args.port, args.speed, args.token, args.task
        )
        replay.start()
    except JudoError as err:
        fail(str(err))
    print(f"replaying {args.file} at {replay.url} (Ctrl-C to stop)", file=sys.stderr)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        return 0
    finally:
        replay.stop()
