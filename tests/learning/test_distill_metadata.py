"""distill rebuilds a task's policy observation with the system metadata collect recorded
(quadruped_velocity's command): row for row what the closed loop fed a policy at run time; a file
without it is refused in one line."""

import numpy as np
import pytest

from judo.core.policy import Policy
from judo.evaluation.seeded import EpisodeSpec, run_seeded_episode
from judo.learning.pairs import DistillError, episode_observations, read_pairs
from judo.recording.dataset import DatasetFile
from judo.recording.recorder import EpisodeRecorder
from judo.tasks.quadruped_velocity import QuadrupedVelocity

h5py = pytest.importorskip("h5py")

DURATION, PERIOD = 1.3, 0.5
"""130 plant steps with the command redrawn every 0.5 s: three commands."""


class SeeingPolicy(Policy):
    """quadruped_velocity's per-step policy that keeps every observation it is given, and walks by
    the command."""

    observation_size, action_size, horizon = 35, 12, 1

    def __init__(self) -> None:
        # acts at every plant step
        self.metadata = {"task": "quadruped_velocity", "control_freq": "100.0"}
        self.home = QuadrupedVelocity().home_ctrl
        self.seen: list[np.ndarray] = []

    def act(self, observations: np.ndarray) -> np.ndarray:
        self.seen.append(np.array(observations))
        # the command's vx, the joints
        swing = 0.1 * np.tanh(observations[:, 30:31] + observations[:, :12])
        return (self.home + swing)[:, None, :]


@pytest.fixture(scope="module")
def policy_file(tmp_path_factory):
    """(file, what the policy saw at each update): seed 0 of a policy-driven quadruped_velocity
    episode, recorded as collect records it."""
    policy, made = SeeingPolicy(), []

    def recorders(controller, system):
        model = system.task.sim_model
        made.append(
            EpisodeRecorder(
                model.nq,
                model.nv,
                model.nmocap,
                1,
                model.nu,
                recorded_metadata=("velocity_command",),
            )
        )
        return made

    values = {"task.resample_period": PERIOD}
    spec = EpisodeSpec("quadruped_velocity", None, DURATION, values=values, policy=policy)  # type: ignore[arg-type]
    result = run_seeded_episode(spec, 0, recorders)
    path = tmp_path_factory.mktemp("distill_metadata") / "quadruped_velocity.h5"
    DatasetFile(path, {"task": "quadruped_velocity", "plant_timestep": 0.01}).write_episode(
        made[0].episode(0, result.rewards, result.metrics, None)
    )
    return path, np.concatenate(policy.seen)


def test_the_rebuilt_observations_are_what_the_policy_saw_in_the_closed_loop(policy_file):
    path, seen = policy_file
    # at t = 0 (before any step) and after each of the first 129 steps
    assert seen.shape == (130, 35)
    pairs = read_pairs([path], "action")
    # the state after step s (its observation) gives the action of step s + 1: rows 0..128, seen at
    # t = 0.01..1.29 equal but for the gait clock's last bits: the rebuild's time is (row + 1) dt,
    # the plant's a running sum
    np.testing.assert_allclose(pairs.observations[0], seen[1:], rtol=0, atol=1e-12)
    commands = np.unique(seen[:, 30:33], axis=0)
    assert len(commands) == 3  # the command changed twice, and the rebuilt rows followed it
    chunk = read_pairs([path], "chunk")  # each update's reading: the same rows
    np.testing.assert_allclose(chunk.observations[0], seen[1:], rtol=0, atol=1e-12)
    with h5py.File(path, "r") as file:
        demo = file["data/demo_0"]
        states = np.concatenate([demo["obs/qpos"][:], demo["obs/qvel"][:]], axis=1)
        served = demo["actions"][:]
    # no command recorded
    without = episode_observations(QuadrupedVelocity(), states, None, served, 0.01)
    # a fresh task's own command instead of the plant's
    assert not np.array_equal(without[:-1], seen[1:])


def test_a_file_without_the_command_is_refused_in_one_line_saying_to_collect_again(
    policy_file, tmp_path, capsys
):
    path, _ = policy_file
    old = tmp_path / "old.h5"
    old.write_bytes(path.read_bytes())
    with h5py.File(old, "a") as file:
        del file["data/demo_0/obs/metadata"]  # as collect wrote it before it kept the metadata
    message = (
        f"'{old}' demo_0 has no obs/metadata/velocity_command, the system metadata "
        "QuadrupedVelocity's observation "
        "reads; collect the dataset again with this judo, which records it"
    )
    with pytest.raises(DistillError) as err:
        read_pairs([old], "chunk")
    assert str(err.value) == message
    for module in ("jax", "optax", "onnx"):
        pytest.importorskip(module)
    from judo.learning.distill import main as distill_main

    with pytest.raises(SystemExit) as exit_info:
        distill_main([str(old), "--out", str(tmp_path / "p.onnx")])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.strip().splitlines() == [f"error: {message}"]
