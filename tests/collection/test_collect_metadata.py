"""The system metadata a task records (`Task.recorded_metadata`): collect keeps each step's value
under obs/metadata/<key>, exactly what the plant published; a task that declares a key it does not
publish is named; replay reads files with and without the group."""

from pathlib import Path

import numpy as np
import pytest

from judo.core.errors import JudoError
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode
from judo.loop.records import StepRecord
from judo.recording.dataset import DatasetFile
from judo.recording.recorder import EpisodeRecorder
from judo.runtime.gui.replay_episodes import check_demos, read_demos
from judo.tasks.pendulum import Pendulum
from judo.tasks.quadruped_velocity import QuadrupedVelocity

h5py = pytest.importorskip("h5py")

DOC = (Path(__file__).resolve().parents[2] / "docs" / "collect.md").read_text()

SPEC = EpisodeSpec(
    "quadruped_velocity",
    "ps",
    1.3,
    values={"task.resample_period": 0.5, "optimizer.num_rollouts": 8},
)
"""130 steps of quadruped_velocity under a command redrawn every 0.5 s: three commands."""


@pytest.fixture(scope="module")
def quadruped_file(tmp_path_factory):
    """(file, the episode's plant task, its step times): seed 0 of SPEC recorded as collect records
    it (without Ray)."""
    made = []

    def recorders(controller, system):
        made.append((EpisodeRecorder.for_loop(controller, system.task), system.task))
        return [made[-1][0]]

    result = run_seeded_episode(SPEC, 0, recorders)
    recorder, plant = made[0]
    path = tmp_path_factory.mktemp("metadata") / "quadruped_velocity.h5"
    dataset = DatasetFile(
        path, {"task": "quadruped_velocity", "optimizer": "ps", "plant_timestep": 0.01}
    )
    dataset.write_episode(
        recorder.episode(0, result.rewards, result.metrics, plant.success(result.metrics))
    )
    return path, plant, np.array([record.time for record in recorder.steps])


def test_each_steps_command_is_kept_as_the_plant_published_it(quadruped_file):
    path, plant, times = quadruped_file
    with h5py.File(path, "r") as file:
        demo = file["data/demo_0"]
        commands = demo["obs/metadata/velocity_command"]
        assert commands.shape == (130, 3) and commands.dtype == np.float64
        commands = commands[:]
        assert sorted(demo["obs/metadata"]) == ["velocity_command"]
    assert "| `data/demo_<seed>/obs/metadata/<key>` | (S, *shape) | float64 |" in DOC
    # the command in force during each step: the plant's latest draw at the step's start (its own
    # log of draws)
    drawn_at, drawn = zip(*plant.command_log, strict=True)
    starts = np.concatenate([[0.0], times[:-1]])
    np.testing.assert_array_equal(
        commands, np.array(drawn)[np.searchsorted(drawn_at, starts, side="right") - 1]
    )
    changes = np.flatnonzero(np.any(np.diff(commands, axis=0) != 0, axis=1)) + 1
    assert changes.tolist() == [50, 100]  # redrawn every 0.5 s: three distinct commands
    config = plant.config
    assert np.all(commands[:, 0] >= -config.max_backward) and np.all(
        commands[:, 0] <= config.max_forward
    )
    assert np.all(np.abs(commands[:, 1:]) <= [config.max_sideways, config.max_yaw_rate])


def test_replay_reads_a_file_with_the_metadata_group_and_one_without(quadruped_file, tmp_path):
    path, plant, _ = quadruped_file
    old = tmp_path / "old.h5"
    old.write_bytes(path.read_bytes())
    with h5py.File(old, "a") as file:
        del file["data/demo_0/obs/metadata"]  # a file collected before judo kept the metadata
    for each in (path, old):
        env_args, demos = read_demos(each)
        check_demos(each, demos, plant.sim_model, env_args["task"])
        assert demos[0].qpos.shape == (130, plant.sim_model.nq)


def step(metadata: dict) -> StepRecord:
    return StepRecord(0.25, np.zeros(2), np.zeros(0), np.zeros(1), metadata)


def test_a_declared_key_missing_from_a_step_or_changing_shape_is_an_error_naming_task_and_key():
    recorder = EpisodeRecorder(
        1, 1, 0, 3, 1, recorded_metadata=("wind",), task_name="WindyPendulum"
    )
    with pytest.raises(JudoError) as err:
        recorder.on_step(step({"other": 1.0}))
    assert str(err.value) == (
        "WindyPendulum records system metadata 'wind' (Task.recorded_metadata), but its step "
        "at t = 0.25 s "
        "published none (its metadata holds ['other'])"
    )
    recorder.on_step(step({"wind": [1.0, 2.0]}))
    with pytest.raises(
        JudoError,
        match=r"'wind' .* published shape "
        r"\(3,\), the first step \(2,\)$",
    ):
        recorder.on_step(step({"wind": [1.0, 2.0, 3.0]}))
    with pytest.raises(JudoError, match=r"'wind' .* published str, not numbers$"):
        recorder.on_step(step({"wind": "strong"}))
    recorder.on_step(step({"wind": np.array([3.0, 4.0])}))
    episode = recorder.episode(0, np.zeros(2), {}, None)
    np.testing.assert_array_equal(episode.metadata["wind"], [[1.0, 2.0], [3.0, 4.0]])


def test_a_task_that_declares_an_unpublished_key_fails_its_episode_naming_both(tmp_path):
    from judo.collection.episode import collect_episode
    from judo.core.configuration.registry import register_task
    from tests.conftest import TINY_CARTPOLE_XML, UprightConfig, UprightTask

    model_path = tmp_path / "tiny.xml"
    model_path.write_text(TINY_CARTPOLE_XML)

    class WindyUpright(UprightTask):
        recorded_metadata = ("wind",)

        def __init__(self):
            super().__init__(model_path)

    register_task("windy_upright", WindyUpright, UprightConfig)
    outcome = collect_episode(EpisodeSpec("windy_upright", "ps", 0.05), 0)
    assert outcome.episode is None
    assert outcome.failure.startswith(
        "JudoError: WindyUpright records system metadata 'wind' (Task.recorded_metadata)"
    )


@pytest.mark.parametrize("bad", ["wind", ("mocap_pos",), ("a/b",), ("",)])
def test_a_task_declaring_keys_wrongly_is_refused_as_its_class_is_made(bad):
    with pytest.raises(TypeError, match=r"^Bad\.recorded_metadata "):
        type("Bad", (Pendulum,), {"recorded_metadata": bad})
    assert (
        QuadrupedVelocity.recorded_metadata == ("velocity_command",)
        and Pendulum.recorded_metadata == ()
    )
