"""The last-line filter at serve time holds a bad Policy; without limits nothing changes, bit for
bit."""

import numpy as np

from judo.core.configuration.registry import make_controller, make_task
from judo.core.policies.policy_controller import make_policy_controller
from judo.core.policy import Policy
from judo.evaluation.episode import run_episode
from judo.loop.closed_loop import ClosedLoop
from judo.loop.records import StepRecord
from judo.loop.system import MujocoSystem
from judo.safety.config import SafetyConfig
from judo.safety.limits import resolve
from judo.safety.serve_filter import ServeFilter, safety_guard


class Rogue(Policy):
    """Pushes the cart as hard as it can, always: into the cart's limit."""

    observation_size, action_size, horizon, metadata = 5, 1, 1, {}

    def act(self, observations: np.ndarray) -> np.ndarray:
        return np.full((len(observations), 1, 1), 1e9)


class BangBang(Rogue):
    """Pushes as hard as it can against the cart's velocity: a jump across the whole range at every
    sign change."""

    def act(self, observations: np.ndarray) -> np.ndarray:
        return (-1e9 * np.sign(observations[:, 3]) + 1e-9)[:, None, None]


class Steps:
    def __init__(self) -> None:
        self.steps: list[StepRecord] = []

    def on_plan(self, record) -> None:
        pass

    def on_step(self, record: StepRecord) -> None:
        self.steps.append(record)


def test_the_filter_holds_a_rogue_policy_within_effort_speed_and_position():
    controller = make_policy_controller("cartpole", Rogue(), seed=0)
    limits = SafetyConfig(
        position=("slider=-0.5:0.5",), velocity=("slider=0.5",), effort=("push=0.8",)
    )
    steps = Steps()
    loop = ClosedLoop(
        controller,
        MujocoSystem.from_task(controller.task, seed=0),
        guard=safety_guard(controller, limits),
        recorders=[steps],
    )
    loop.restart()
    for _ in range(300):
        loop.step()
    served = np.array([record.action[0] for record in steps.steps])
    cart = np.array([record.state[0] for record in steps.steps])
    # the motor's force is 1 per unit of command: the cap holds every command
    assert np.abs(served).max() <= 0.8
    assert cart.max() <= 0.5 + 0.02  # a step's overshoot at most, at the speed limit
    assert loop.guard.counts["effort:push"] == 300 and loop.guard.counts["position:slider"] > 0
    hits = [hit for record in steps.steps for hit in record.limit_hits]
    assert len(hits) == sum(loop.guard.counts.values())
    assert {hit.limit for hit in hits} >= {"effort:push", "position:slider"}
    assert "serving the safe action" in loop.guard.status or "clamped" in loop.guard.status


def test_non_finite_commands_and_readings_get_the_safe_action():
    task = make_task("cartpole")
    guard = ServeFilter(task, resolve(task, SafetyConfig(rate=("push=10",))))
    safe = lambda: np.zeros(1)  # noqa: E731
    state = np.array([0.0, np.pi, 0.0, 0.0])
    assert guard.filter(np.array([np.nan]), state, 0.0, safe).tolist() == [0.0]
    assert guard.filter(np.array([1.0]), np.array([np.nan, 0, 0, 0]), 0.01, safe).tolist() == [0.0]
    # 10 per s for 0.01 s
    assert guard.filter(np.array([1.0]), state, 0.02, safe) == np.array([0.1])
    assert [hit.limit for hit in guard.hits] == [
        "non-finite command",
        "non-finite reading",
        "rate:push",
    ]


def test_a_position_actuators_command_is_clamped_to_the_torque_its_pd_implies():
    task = make_task("quadruped")
    guard = ServeFilter(task, resolve(task, SafetyConfig(effort=("*=2",))))
    model = task.model
    state = np.concatenate([model.key_qpos[0] if model.nkey else model.qpos0, np.zeros(model.nv)])
    served = guard.filter(
        np.clip(state[7:19] + 1.0, *task.command_range.T), state, 0.0, lambda: np.zeros(model.nu)
    )
    force = guard.limits.effort_of(served, state[: model.nq], state[model.nq :])
    assert np.abs(force).max() <= 2 + 1e-9 and len(guard.hits) == model.nu


def test_no_limits_change_nothing():
    def actions(safety):
        controller = make_controller("cartpole", "ps", seed=4)
        steps = Steps()
        loop = ClosedLoop(
            controller,
            MujocoSystem.from_task(controller.task, seed=4),
            guard=safety_guard(controller, safety),
            recorders=[steps],
        )
        loop.restart()
        for _ in range(25):
            loop.step()
        assert loop.guard is None and controller.limits is None
        controller.close()
        return np.array([record.action for record in steps.steps])

    assert np.array_equal(actions(None), actions(SafetyConfig()))


def test_an_episode_reports_its_limit_hits_as_a_metric():
    controller = make_policy_controller("cartpole", BangBang(), seed=5)
    system = MujocoSystem.from_task(controller.task, seed=5)
    result = run_episode(controller, system, 0.5, safety=SafetyConfig(rate=("push=5",)))
    assert result.metrics["limit_hits"] == sum(result.limit_hits.values()) > 0
    assert set(result.limit_hits) == {"rate:push"}
    assert np.abs(np.diff(result.log.controls[:, 0])).max() <= 5 * system.timestep + 1e-12
    plain = run_episode(controller, MujocoSystem.from_task(controller.task, seed=5), 0.1)
    assert "limit_hits" not in plain.metrics and plain.limit_hits == {}


def test_the_hits_reach_the_dataset(tmp_path):
    import h5py

    from judo.recording.dataset import write_demo
    from judo.recording.recorder import EpisodeRecorder

    controller = make_policy_controller("cartpole", BangBang(), seed=6)
    model = controller.task.model
    recorder = EpisodeRecorder(model.nq, model.nv, model.nmocap, 1, model.nu)
    loop = ClosedLoop(
        controller,
        MujocoSystem.from_task(controller.task, seed=6),
        guard=safety_guard(controller, SafetyConfig(rate=("push=5",))),
        recorders=[recorder],
    )
    loop.restart()
    for _ in range(50):
        loop.step()
    episode = recorder.episode(6, np.zeros(50), {}, None)
    with h5py.File(tmp_path / "d.h5", "w") as file:
        write_demo(file.create_group("demo_6"), episode)
    with h5py.File(tmp_path / "d.h5", "r") as file:
        limits = [name.decode() for name in file["demo_6/limit_hits/limit"][:]]
        times = file["demo_6/limit_hits/time"][:]
    assert limits == [hit.limit for hit in loop.guard.hits] and set(limits) == {"rate:push"}
    assert len(times) == sum(loop.guard.counts.values()) > 0
