"""The leaderboard's protocols, its refusals at the boundary, and its table's winners: no Ray, no
study."""

import pytest

from judo.builtin import BUILTIN_TASKS
from judo.core.configuration.registry import lookup_task
from judo.tuning.leaderboard import main as leaderboard_main
from judo.tuning.leaderboard_protocol import SHIPPED, ProtocolError, load_protocol
from judo.tuning.leaderboard_report import Cell, markdown_table, winners

pytest.importorskip("optuna")
pytest.importorskip("ray")

PENDULUM = """metric = "upright_fraction"
control_freq = 20.0
horizon = 1.5
num_nodes = 4
num_rollouts = 16
duration = 1.0
tuning_seeds = 1
"""


def refusal(capsys, *argv: str) -> str:
    """The one line `python -m judo leaderboard ARGV` exits 2 with."""
    with pytest.raises(SystemExit) as exit_info:
        leaderboard_main(list(argv))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


def test_every_built_in_task_ships_a_protocol_that_loads_with_the_sign_of_its_metric():
    for task in BUILTIN_TASKS:
        protocol = load_protocol(task)
        assert protocol.path == str(SHIPPED / f"{task}.toml")
        lower = protocol.metric in lookup_task(task)[0].lower_is_better
        assert protocol.direction == ("minimize" if lower else "maximize"), task
        assert protocol.tuning_first_seed >= 1000, (
            "validation runs seeds 0 to --seeds - 1; tuning must not"
        )


def test_a_protocol_of_ones_own_is_read_first_and_its_missing_settings_are_the_tasks(tmp_path):
    (tmp_path / "pendulum.toml").write_text('metric = "mean_reward"\nnum_rollouts = 8\n')
    protocol = load_protocol("pendulum", tmp_path)
    shipped = load_protocol("pendulum")
    assert (protocol.metric, protocol.num_rollouts, protocol.path) == (
        "mean_reward",
        8,
        str(tmp_path / "pendulum.toml"),
    )
    assert (protocol.horizon, protocol.spline_order, protocol.control_freq) == (1.5, "cubic", 20.0)
    assert protocol.digest() != shipped.digest()
    assert protocol.fixed() == {
        "controller.horizon": 1.5,
        "controller.spline_order": "cubic",
        "optimizer.num_nodes": 4,
        "optimizer.num_rollouts": 8,
    }


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            'metric = "x"\nrate = 20\n',
            "unknown key 'rate'; valid keys are: metric, direction, control_freq",
        ),
        ("horizon = 1.0\n", "metric must name one of the task's evaluate metrics"),
        ('metric = "x"\ndirection = "up"\n', "direction must be maximize or minimize, got 'up'"),
        ('metric = "x"\nnum_nodes = 2.5\n', "num_nodes must be an integer, got 2.5"),
        (
            'metric = "x"\nnum_nodes = 3\n',
            "a cubic spline needs at least 4 knots, got num_nodes = 3",
        ),
        ('metric = "x"\nduration = 0\n', "duration must be above 0"),
        (
            'metric = "x"\ncontrol_freq = "fast"\n',
            "control_freq must be a finite number, got 'fast'",
        ),
        ("metric = \n", "cannot be read as TOML"),
    ],
)
def test_a_bad_protocol_is_refused_naming_its_file_and_key(tmp_path, text, message):
    (tmp_path / "pendulum.toml").write_text(text)
    with pytest.raises(ProtocolError) as error:
        load_protocol("pendulum", tmp_path)
    assert str(error.value).startswith(f"{tmp_path / 'pendulum.toml'}: ") and message in str(
        error.value
    )


def test_unknown_names_are_refused_in_one_line_listing_the_valid_ones(capsys, tmp_path):
    err = refusal(capsys, "--tasks", "pendulum", "nope", "--out", str(tmp_path))
    assert err.startswith("error: unknown task 'nope'; valid tasks are: ") and "cartpole, " in err
    err = refusal(
        capsys, "--tasks", "pendulum", "--optimizers", "mppi", "best", "--out", str(tmp_path)
    )
    assert (
        err.startswith("error: unknown optimizer 'best'; valid optimizers are: ") and "mppi" in err
    )
    assert refusal(capsys, "--tasks", "pendulum", "--trials", "0") == (
        "error: --trials must be an integer from 1 to 100000, got 0"
    )
    assert not (tmp_path / "leaderboard.db").exists()


def test_a_task_without_a_protocol_and_a_metric_it_does_not_report_are_refused(
    capsys, tmp_path, monkeypatch
):
    monkeypatch.setattr("judo.tuning.leaderboard_protocol.SHIPPED", tmp_path / "none")
    err = refusal(
        capsys, "--tasks", "acrobot", "--protocols", str(tmp_path), "--out", str(tmp_path / "out")
    )
    assert (
        err.startswith("error: task 'acrobot' has no protocol file acrobot.toml in ")
        and "--protocols DIR" in err
    )
    monkeypatch.undo()
    (tmp_path / "pendulum.toml").write_text(PENDULUM.replace("upright_fraction", "smiles"))
    err = refusal(
        capsys, "--tasks", "pendulum", "--protocols", str(tmp_path), "--out", str(tmp_path / "out")
    )
    assert err.startswith(
        "error: task 'pendulum' reports no metric 'smiles'; its metrics are: upright_fraction"
    )


def test_tuning_seeds_that_overlap_the_validation_seeds_are_refused(capsys, tmp_path):
    (tmp_path / "pendulum.toml").write_text(PENDULUM + "tuning_first_seed = 5\n")
    err = refusal(
        capsys,
        "--tasks",
        "pendulum",
        "--seeds",
        "6",
        "--protocols",
        str(tmp_path),
        "--out",
        str(tmp_path),
    )
    assert err == (
        f"error: {tmp_path / 'pendulum.toml'}: its tuning seeds (from tuning_first_seed = 5) "
        "overlap the validation "
        "seeds 0 to 5; give fewer --seeds or a tuning_first_seed of 6 or more"
    )


def test_the_winner_is_the_best_mean_in_the_protocols_direction_and_bold_in_markdown(tmp_path):
    (tmp_path / "pendulum.toml").write_text(PENDULUM)
    (tmp_path / "push_t.toml").write_text('metric = "final_position_error"\n')
    protocols = {task: load_protocol(task, tmp_path) for task in ("pendulum", "push_t")}
    cells = [
        Cell("pendulum", "ps", "ps", scores=[0.9, 1.0]),
        Cell("pendulum", "mppi", "mppi", scores=[0.6, 0.7]),
        Cell("pendulum", "cem", "cem", failure="no completed trial"),
        Cell("push_t", "ps", "ps", scores=[3.0, 1.0]),
        Cell("push_t", "mppi", "mppi", scores=[0.5, 1.5]),
        Cell("push_t", "cem", "cem", scores=[1.0, 1.0]),
    ]
    assert winners(cells[:3], protocols["pendulum"]) == {"ps"}
    assert winners(cells[3:], protocols["push_t"]) == {"mppi", "cem"}  # a tie: both win
    lines = markdown_table(cells, protocols).splitlines()
    assert lines[0] == "| optimizer | pendulum upright_fraction ↑ | push_t final_position_error ↓ |"
    assert lines[2] == "| ps | **0.95 ± 0.635** | 2 ± 12.7 |"
    assert lines[3] == "| mppi | 0.65 ± 0.635 | **1 ± 6.35** |"
    assert lines[4] == "| cem | failed | **1 ± 0** |"


def test_the_validation_store_is_written_whole_and_a_broken_one_is_refused(tmp_path):
    from judo.core.errors import JudoError
    from judo.tuning.leaderboard_validation import load_store, save_store

    path = tmp_path / "validation.json"
    assert load_store(path) == {}
    save_store(
        path,
        {"pendulum|ps|x|trial 0|2 seeds": {"scores": [0.5, 1.0], "failure": None, "plan_ms": 3.0}},
    )
    assert load_store(path)["pendulum|ps|x|trial 0|2 seeds"]["scores"] == [0.5, 1.0]
    assert [p.name for p in tmp_path.iterdir()] == ["validation.json"]
    path.write_text('{"pendulum|ps": ')  # cut short by hand
    with pytest.raises(
        JudoError,
        match=r"validation.json holds no stored "
        r"validations \(.*\); delete it to validate",
    ):
        load_store(path)
