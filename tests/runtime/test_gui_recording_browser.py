"""The GUI's record toggle in headless Chromium: ticking and unticking it writes a file replay
opens.

(A browser test lives in a test_gui_*_browser.py file: the session's Chromium keeps playwright's
event loop in the main thread once it starts, so it must start after the tests that call App.run()
there.)"""

import pytest

import judo
from judo.runtime.app import App
from judo.runtime.gui.replay_episodes import read_demos

pytest.importorskip("h5py")


def small_recording_app(**kwargs) -> App:
    controller = judo.ControllerConfig(horizon=0.3, control_freq=20.0)
    return App("cartpole", "ps", controller_config=controller, seed=0, num_workers=1, **kwargs)


@pytest.mark.browser
def test_the_record_toggle_in_the_browser_writes_a_file_that_replay_opens(
    panel_page, port, tmp_path, monkeypatch, wait_until, pause_scene
):
    monkeypatch.chdir(tmp_path)  # the default recording path is in the working folder
    app = small_recording_app(port=port)
    app.start()
    page = panel_page(viewport={"width": 1280, "height": 900})
    page.set_default_timeout(60_000)
    try:
        page.goto(app.gui.url)
        page.get_by_text("Controller", exact=True).wait_for()
        pause_scene(page)
        record = page.get_by_text("record", exact=True)
        record.wait_for()
        record.click()
        wait_until(lambda: app.recording is not None, timeout=30, what="the recording to start")
        plans = app.stats.num_plans()
        wait_until(
            lambda: app.stats.num_plans() >= plans + 3, timeout=30, what="three plans recorded"
        )
        record.click()
        wait_until(lambda: app.recording is None, timeout=30, what="the recording to be written")
        wait_until(
            lambda: "recorded " in app.status.message, timeout=10, what="the status to say so"
        )
    finally:
        page.close()
        app.stop()
    files = list(tmp_path.glob("judo-recording-cartpole-*.h5"))
    assert len(files) == 1
    _, demos = read_demos(files[0])
    assert len(demos[0].qpos) > 10
