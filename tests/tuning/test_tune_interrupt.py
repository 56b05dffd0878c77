"""A Ctrl-C that lands anywhere in the study's loop leaves no trial RUNNING, and a trial whose
process died is found by its heartbeat: real signals to this process, a real local Ray and a real
SQLite study.

A SIGINT sent with os.kill to this process is handled at the next bytecode, so sending it from
inside the loop's own calls (Ray's submit, the study's tell) puts the Ctrl-C exactly where a loaded
machine once put it by chance: between asking Optuna for a trial and the loop knowing of it, or
between a trial's last episode and its tell.
"""

import os
import signal
import time

import pytest

from judo.tuning import heartbeat
from judo.tuning import study as studies
from judo.tuning.objective import Objective
from judo.tuning.space import Param
from judo.tuning.trial import TrialSpec

optuna = pytest.importorskip("optuna")
pytest.importorskip("ray")  # the local_ray fixture is in tests/conftest.py

SPACE = [Param("optimizer", "sigma", 0.01, 1.0, log=True)]
SPEC = TrialSpec("cartpole", "ps", "mean_reward", 1, 0.2, fixed={"optimizer.num_rollouts": 16})


def sqlite_study(tmp_path, name="interrupted"):
    storage = f"sqlite:///{tmp_path / 'tune.db'}"
    sampler = studies.make_sampler("random", 0, SPACE, constrained=False)
    study, already, notes = studies.open_study(
        storage, name, Objective("mean_reward", "maximize"), sampler, {}
    )
    assert (already, notes) == (0, [])
    return study, storage


def states(study) -> list[str]:
    return [trial.state.name for trial in study.get_trials(deepcopy=False)]


@pytest.mark.slow
def test_ctrl_c_while_a_trial_is_submitted_fails_that_trial(local_ray, tmp_path, monkeypatch):
    study, _ = sqlite_study(tmp_path)
    real_submit, calls = studies.submit, []

    def submit_with_ctrl_c(*args):
        calls.append(args)
        if len(calls) == 2:  # the second trial's episode: trial 1 is RUNNING in the storage already
            os.kill(os.getpid(), signal.SIGINT)
        return real_submit(*args)

    monkeypatch.setattr(studies, "submit", submit_with_ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        studies.run_trials(study, SPACE, SPEC, target=3, concurrency=1, max_plan_ms=None)
    assert states(study) == ["COMPLETE", "FAIL"]
    assert study.trials[1].user_attrs["failure"] == "interrupted"


def test_ctrl_c_while_a_finished_trial_is_told_stores_it_complete(local_ray, tmp_path, monkeypatch):
    study, _ = sqlite_study(tmp_path)
    real_tell = studies.tell

    def tell_with_ctrl_c(*args):
        os.kill(os.getpid(), signal.SIGINT)
        real_tell(*args)

    monkeypatch.setattr(studies, "tell", tell_with_ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        studies.run_trials(study, SPACE, SPEC, target=3, concurrency=1, max_plan_ms=None)
    assert states(study) == ["COMPLETE"]  # told, and no second trial started
    assert (
        study.trials[0].value is not None and "mean_reward" in study.trials[0].user_attrs["metrics"]
    )


def test_a_running_trial_beats_and_one_that_stopped_beating_is_failed_and_named(tmp_path):
    study, storage = sqlite_study(tmp_path, "beats")
    trial = study.ask()
    with heartbeat.Heartbeats(study) as beats:
        beats.beat(trial)
        assert heartbeat.dead_trial_notes(study) == [
            "trial 0 still RUNNING: another tune runs it, or its process died less than "
            f"{heartbeat.STALE_AFTER_S} s "
            "ago (a later resume marks it FAIL)"
        ]
    # The same file seen by a storage with a 1 s grace period: trial 0's one heartbeat goes stale in
    # a second or two (SQLite's clock counts whole seconds), as it does after STALE_AFTER_S for
    # tune.
    quick = optuna.storages.RDBStorage(storage, heartbeat_interval=1, grace_period=1)
    seen = optuna.load_study(study_name="beats", storage=quick)
    deadline, notes = time.monotonic() + 60, []
    while time.monotonic() < deadline and not notes:
        time.sleep(0.5)
        notes = [note for note in heartbeat.dead_trial_notes(seen) if "marked FAIL" in note]
    assert notes == ["trial 0 was left RUNNING by a process that died; marked FAIL"]
    (failed,) = seen.get_trials(deepcopy=False)
    assert failed.state.name == "FAIL" and heartbeat.failure_of(failed) == heartbeat.DEAD_PROCESS
