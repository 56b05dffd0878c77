"""`python -m judo replay` in headless Chromium: the robot moves while playing, the scrubber poses
it, and the recorded plans' traces are drawn and follow the scrubber."""

import numpy as np
import pytest

from judo.collection.episode import collect_episode
from judo.evaluation.seeded import EpisodeSpec
from judo.recording.dataset import DatasetFile
from judo.runtime.gui.replay import Replay

pytest.importorskip("h5py")
pytestmark = pytest.mark.browser


@pytest.fixture
def replay(tmp_path, port):
    """A replay of seeds 0 and 1 of 2 s cartpole x ps episodes with their traces, showing seed 1, on
    a free port."""
    path = tmp_path / "cartpole.h5"
    dataset = DatasetFile(path, {"task": "cartpole", "optimizer": "ps", "plant_timestep": 0.01})
    for seed in (0, 1):
        dataset.write_episode(
            collect_episode(EpisodeSpec("cartpole", "ps", 2.0), seed, traces=True).episode
        )
    # 20 s to play the 2 s episode
    replay = Replay(path, demo=1, host="127.0.0.1", port=port, speed=0.1)
    replay.start()
    yield replay
    replay.stop()


def cart_position(replay: Replay) -> np.ndarray:
    """Where the scene's cart frame is (body 1), as sent to the page."""
    return np.array(replay.scene.body_frames[1].position)


def nominal_trace(replay: Replay) -> np.ndarray:
    """(segments, 2, 3) the nominal trace's line segments as sent to the page."""
    return np.array(replay.scene.scene.get_handle_by_name("/traces/nominal").points)


def test_the_robot_moves_and_the_scrubber_changes_the_pose_shown(
    panel_page, replay, wait_until, artifacts, pause_scene
):
    page = panel_page(viewport={"width": 1280, "height": 900})
    page.set_default_timeout(60_000)
    try:
        page.goto(replay.url)
        page.get_by_text("Play", exact=True).wait_for()
        pause_scene(page)
        assert "seed 1" in page.locator(".mantine-Paper-root").first.inner_text()
        start, start_trace = cart_position(replay), nominal_trace(replay)
        assert replay.scene.scene.get_handle_by_name("/traces/samples") is not None
        assert replay.plan_shown == 0 and np.allclose(start_trace[0, 0], replay.traces[0, 0, 0, 0])
        assert replay.index == 0 and np.array_equal(replay.scene.data.qpos, replay.demos[1].qpos[0])
        page.get_by_text("Play", exact=True).click()
        page.get_by_text("Pause", exact=True).wait_for()
        wait_until(lambda: replay.index >= 20, timeout=60, what="the replay to play 20 rows")
        # the cart moved with the recorded qpos
        assert not np.allclose(cart_position(replay), start)
        page.get_by_text("Pause", exact=True).click()
        wait_until(lambda: not replay.playing, timeout=10, what="the replay to pause")
        paused = replay.index
        slider = page.locator(".mantine-Slider-root").first
        box = slider.locator(".mantine-Slider-track").bounding_box()
        page.mouse.click(box["x"] + 0.9 * box["width"], box["y"] + box["height"] / 2)
        wait_until(
            lambda: replay.index > paused + 30, timeout=60, what="the scrubber to move the replay"
        )
        # the index is set first in a frame, the pose and traces after: read a whole frame
        with replay.lock:
            shown, plan_shown, qpos = replay.index, replay.plan_shown, replay.scene.data.qpos.copy()
            # the scrubbed-to time's plan, drawn as the live GUI draws it
            moved_trace = nominal_trace(replay)
        assert np.array_equal(qpos, replay.demos[1].qpos[shown])
        assert 160 <= shown <= 199
        plan_times, row_time = (
            np.append(replay.demos[1].plan_times, np.inf),
            replay.demos[1].times[shown],
        )
        assert plan_times[plan_shown] <= row_time + 1e-9 < plan_times[plan_shown + 1]
        assert np.allclose(moved_trace[0, 0], replay.traces[plan_shown, 0, 0, 0])
        assert not np.allclose(moved_trace, start_trace)
        page.screenshot(path=artifacts / "replay_cartpole.png")
    finally:
        page.close()
