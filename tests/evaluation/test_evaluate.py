import json

import pytest

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import (
    get_registered_optimizers,
    get_registered_tasks,
    make_config,
)
from judo.evaluation.evaluate import main
from judo.evaluation.shared_options import write_json

TINY = [
    "--task",
    "cartpole",
    "--optimizer",
    "ps",
    "--seeds",
    "1",
    "--duration",
    "0.5",
    "--num-workers",
    "1",
]


def evaluate_json(tmp_path, *extra: str) -> dict:
    path = tmp_path / f"eval{len(list(tmp_path.iterdir()))}.json"
    assert main([*TINY, *extra, "--json", str(path)]) == 0
    return json.loads(path.read_text())


def test_evaluate_reports_each_episode_and_the_summary(tmp_path, capsys):
    report = evaluate_json(tmp_path, "--seeds", "2")
    control_freq = make_config(ControllerConfig, "cartpole").control_freq
    assert (report["task"], report["optimizer"], report["seeds"], report["latency"]) == (
        "cartpole",
        "ps",
        2,
        "none",
    )
    assert [episode["seed"] for episode in report["episodes"]] == [0, 1]
    for episode in report["episodes"]:
        assert set(episode["metrics"]) == {"balanced_fraction", "swung_up", "mean_reward"}
        assert episode["num_updates"] == round(0.5 * control_freq)
        assert episode["divergences"] == 0
    summary = report["summary"]["mean_reward"]
    values = [episode["metrics"]["mean_reward"] for episode in report["episodes"]]
    assert summary["mean"] == pytest.approx(sum(values) / 2)
    assert summary["n"] == 2 and summary["ci95"] > 0
    assert (summary["min"], summary["max"]) == (min(values), max(values))
    out = capsys.readouterr().out
    assert "cartpole x ps: 2 seeds x 0.5 s, latency none" in out
    assert "mean ± 95% CI" in out and "balanced_fraction" in out


def test_first_seed_runs_the_seeds_from_it_and_says_so(tmp_path, capsys):
    report = evaluate_json(tmp_path, "--first-seed", "3", "--seeds", "2")
    assert (report["seeds"], report["first_seed"]) == (2, 3)
    assert [episode["seed"] for episode in report["episodes"]] == [3, 4]
    assert "cartpole x ps: 2 seeds (3-4) x 0.5 s, latency none" in capsys.readouterr().out
    # seed 4's episode does not depend on the seeds before it
    alone = evaluate_json(tmp_path, "--first-seed", "4")
    assert [episode["seed"] for episode in alone["episodes"]] == [4]
    assert alone["episodes"][0]["metrics"] == report["episodes"][1]["metrics"]
    assert evaluate_json(tmp_path)["first_seed"] == 0


def test_the_same_seed_gives_the_same_result_twice(tmp_path):
    first, again = evaluate_json(tmp_path), evaluate_json(tmp_path)
    assert first["episodes"][0]["metrics"] == again["episodes"][0]["metrics"]
    assert first["summary"] == again["summary"]


def test_a_fixed_latency_changes_the_result_reproducibly(tmp_path):
    none = evaluate_json(tmp_path)
    delayed, delayed_again = (
        evaluate_json(tmp_path, "--latency-ms", "40"),
        evaluate_json(tmp_path, "--latency-ms", "40"),
    )
    assert delayed["latency"] == "40 ms"
    assert delayed["episodes"][0]["latency_ms_median"] == pytest.approx(40.0)
    assert delayed["episodes"][0]["metrics"] == delayed_again["episodes"][0]["metrics"]
    assert (
        delayed["episodes"][0]["metrics"]["mean_reward"]
        != none["episodes"][0]["metrics"]["mean_reward"]
    )


def test_measured_latency_is_recorded(tmp_path):
    report = evaluate_json(
        tmp_path, "--latency", "measured", "--controller.no-latency-compensation"
    )
    assert report["latency"] == "measured"
    assert report["episodes"][0]["latency_ms_median"] == pytest.approx(
        report["episodes"][0]["update_ms_median"]
    )
    # With compensation (cartpole's default) a plan takes effect at the plant step it was predicted
    # to: no earlier than its update's wall time.
    report = evaluate_json(tmp_path, "--latency", "measured")
    episode = report["episodes"][0]
    assert episode["latency_ms_median"] >= episode["update_ms_median"] - 1e-6


def test_the_plot_is_written_as_html_without_extra_dependencies(tmp_path):
    path = tmp_path / "episode.html"
    assert main([*TINY, "--plot", str(path)]) == 0
    page = path.read_text()
    assert page.startswith("<!DOCTYPE html>")
    for title in ("positions (qpos)", "velocities (qvel)", "controls", "reward per step"):
        assert title in page
    assert "slider" in page and "hinge" in page and page.count("<polyline") == 2 + 2 + 1 + 1


def test_the_plot_is_written_as_png_with_matplotlib(tmp_path):
    pytest.importorskip("matplotlib")
    path = tmp_path / "episode.png"
    assert main([*TINY, "--plot", str(path)]) == 0
    assert path.read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--task", "nope", "--optimizer", "ps"], "unknown task 'nope'; valid tasks are: {tasks}"),
        (
            ["--task", "cartpole", "--optimizer", "nope"],
            "unknown optimizer 'nope'; valid optimizers are: {optimizers}",
        ),
        (
            [*TINY, "--latency", "measured", "--latency-ms", "5"],
            "give either --latency measured or --latency-ms 5.0, not both",
        ),
        ([*TINY, "--seeds", "0"], "--seeds must be between 1 and 10000, got 0"),
        (
            [*TINY, "--seeds", "100000000000"],
            "--seeds must be between 1 and 10000, got 100000000000",
        ),
        ([*TINY, "--duration", "-1"], "--duration must be above 0 and at most 86400.0 s, got -1.0"),
        ([*TINY, "--duration", "inf"], "--duration must be above 0 and at most 86400.0 s, got inf"),
        ([*TINY, "--duration", "nan"], "--duration must be above 0 and at most 86400.0 s, got nan"),
        ([*TINY, "--latency-ms", "inf"], "--latency-ms must be between 0 and 60000.0, got inf"),
        (
            [*TINY, "--plot", "episode.svg"],
            "--plot needs a file ending in .png or .html, got 'episode.svg'",
        ),
    ],
)
def test_bad_arguments_give_a_message_and_no_traceback(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    tasks, optimizers = (
        ", ".join(sorted(get_registered_tasks())),
        ", ".join(sorted(get_registered_optimizers())),
    )
    assert (
        capsys.readouterr().err
        == "error: " + message.format(tasks=tasks, optimizers=optimizers) + "\n"
    )


def test_help_lists_the_flags(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    for flag in (
        "--task",
        "--optimizer",
        "--seeds",
        "--duration",
        "--latency",
        "--latency-ms",
        "--json",
        "--plot",
    ):
        assert flag in out


def test_json_reports_write_nan_and_infinities_as_null(tmp_path):
    path = tmp_path / "report.json"
    write_json(
        path,
        {"metric": float("nan"), "rows": [1.5, float("-inf"), {"x": float("inf")}], "name": "ok"},
    )
    assert json.loads(path.read_text(), parse_constant=pytest.fail) == {
        "metric": None,
        "rows": [1.5, None, {"x": None}],
        "name": "ok",
    }
