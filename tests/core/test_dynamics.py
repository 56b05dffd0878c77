"""Tasks on their own numpy dynamics (judo.core.rollouts.dynamics): the backend against a plain
loop, a user's pendulum swung up by three optimizers, and bad dynamics refused with one line naming
the task."""

from dataclasses import dataclass

import numpy as np
import pytest

from judo.core.configuration.controller_config import ControllerConfig
from judo.core.configuration.registry import get_registered_optimizers
from judo.core.controller import Controller
from judo.core.errors import ConfigError, ModelLoadError, NonFiniteRewardError
from judo.core.norms import wrap_angle
from judo.core.rollouts.dynamics import (
    DivergedDynamicsError,
    DynamicsError,
    DynamicsRollout,
    DynamicsTask,
)
from judo.core.task import TaskConfig
from judo.evaluation.episode import run_episode
from judo.loop.closed_loop import ClosedLoop
from judo.loop.system import DynamicsSystem, MujocoSystem, SimulationDiverged
from judo.optimizers.cem import CEM, CEMConfig
from judo.optimizers.mppi import MPPI, MPPIConfig
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig


@dataclass
class SwingConfig(TaskConfig):
    """Weights of the swing-up."""

    w_upright: float = 10.0
    """Weight on the angle from upright."""


class UserPendulum(DynamicsTask[SwingConfig]):
    """A pendulum a user writes as two lines of numpy: state [angle (0 up), angular velocity],
    torque at most 2 Nm against 4.9 Nm of gravity (1 kg, 0.5 m), semi-implicit Euler at 20 ms."""

    def __init__(self) -> None:
        super().__init__(nx=2, control_range=[[-1.0, 1.0]], dt=0.02)

    def dynamics(self, states: np.ndarray, controls: np.ndarray, dt: float) -> np.ndarray:
        angle, velocity = states[:, 0], states[:, 1]
        velocity = velocity + dt * (
            9.81 / 0.5 * np.sin(angle) + 2.0 * controls[:, 0] / 0.25 - 0.1 * velocity
        )
        return np.stack([angle + dt * velocity, velocity], axis=1)

    def reward(self, states, sensors, controls, config, system_metadata=None) -> np.ndarray:
        upright = np.abs(wrap_angle(states[..., 0]))
        return -(config.w_upright * upright.sum(-1) + 0.05 * (states[..., 1] ** 2).sum(-1))

    def initial_state(self) -> np.ndarray:
        return np.array([np.pi + self.rng.uniform(-0.2, 0.2), 0.0])


def test_backend_equals_a_plain_python_loop_bit_for_bit():
    task = UserPendulum()
    rng = np.random.default_rng(0)
    controls = rng.uniform(-1, 1, (7, 25, 1))
    x0 = np.array([2.5, -0.3])
    with DynamicsRollout(task) as backend:
        states, sensors = backend.rollout(np.concatenate([[1.5], x0]), controls)
    assert sensors.shape == (7, 25, 0)
    for i in range(7):
        x = x0[None]
        for t in range(25):
            x = task.dynamics(x, controls[i, t][None], task.dt)
            assert np.array_equal(states[i, t, 1:3], x[0])
            assert states[i, t, 0] == 1.5 + task.dt * (t + 1)


def test_the_controller_chooses_the_dynamics_backend_and_refuses_warp():
    task = UserPendulum()
    with Controller(
        ControllerConfig(horizon=0.5), task, MPPI(MPPIConfig(num_rollouts=8), 1)
    ) as controller:
        assert isinstance(controller.backend, DynamicsRollout)
    with pytest.raises(
        ConfigError,
        match=r"^UserPendulum rolls out its own "
        r"dynamics.*expected backend 'cpu'.*got 'warp'$",
    ):
        Controller(ControllerConfig(), task, MPPI(MPPIConfig(), 1), backend="warp")


@pytest.mark.parametrize(
    ("optimizer", "config"),
    [
        (MPPI, MPPIConfig(num_rollouts=32, num_nodes=4, sigma=0.3, temperature=0.1)),
        (PredictiveSampling, PredictiveSamplingConfig(num_rollouts=32, num_nodes=4, sigma=0.3)),
        (CEM, CEMConfig(num_rollouts=32, num_nodes=4, sigma_min=0.1, sigma_max=0.8, num_elites=4)),
    ],
    ids=["mppi", "ps", "cem"],
)
def test_a_user_pendulum_swings_up(optimizer, config):
    """Every optimizer swings the user's pendulum up from hanging and holds it: within 0.3 rad of
    upright over the last 2 s of 6 s (measured: the pole is up after about 2-3 s)."""
    task = UserPendulum()
    task.rng = np.random.default_rng(1)
    optimizer_ = optimizer(config, 1)
    optimizer_.rng = np.random.default_rng(2)
    controller = Controller(
        ControllerConfig(horizon=1.5, spline_order="cubic", control_freq=20.0), task, optimizer_
    )
    system = MujocoSystem.from_task(task, seed=3)
    assert isinstance(system, DynamicsSystem)
    with controller:
        result = run_episode(controller, system, duration=6.0)
    angle = np.abs(wrap_angle(result.log.states[:, 0]))
    assert result.log.states.shape == (300, 2)
    assert angle[0] > 2.5
    assert (angle[-100:] < 0.3).all(), angle[-100:].max()


class WrongShape(UserPendulum):
    def dynamics(self, states, controls, dt):
        return states[:, :1]


class NanAfterAWhile(UserPendulum):
    def dynamics(self, states, controls, dt):
        out = super().dynamics(states, controls, dt)
        out[controls[:, 0] > 0.5] = np.nan  # rows pushing hard diverge
        return out

    def reward(self, states, sensors, controls, config, system_metadata=None):
        # NaN would "win"
        return np.nan_to_num(super().reward(states, sensors, controls, config), nan=1e9)


def test_wrong_output_shape_is_one_line_naming_the_task():
    with DynamicsRollout(WrongShape()) as backend, pytest.raises(DynamicsError) as err:
        backend.rollout(np.zeros(6), np.zeros((4, 3, 1)))
    assert str(err.value) == "WrongShape.dynamics returned shape (4, 1), expected (4, 2) = (N, nx)"


def test_a_nan_rollout_never_wins_and_all_nan_is_one_line():
    task = NanAfterAWhile()
    controller = Controller(
        ControllerConfig(horizon=0.2, max_num_traces=0),
        task,
        MPPI(MPPIConfig(num_rollouts=16, sigma=0.5), 1),
    )
    with controller:
        controller.update_action(np.array([np.pi, 0.0]), 0.0)
        diverged = controller.backend.diverged
        assert diverged.any() and not diverged.all()
        assert (controller.rewards[diverged] == -np.inf).all()
        assert np.isfinite(controller.rewards[~diverged]).all()
    with DynamicsRollout(task) as backend, pytest.raises(DynamicsError) as err:
        backend.rollout(np.zeros(6), np.ones((4, 3, 1)))
    assert str(err.value) == (
        "NanAfterAWhile.dynamics gave NaN or infinite states in all 4 rollouts; expected "
        "finite states "
        "(check the step for divisions by zero or a too large dt)"
    )
    # a failed update, like every rollout scoring -inf
    assert isinstance(err.value, NonFiniteRewardError)


def test_a_cycle_whose_rollouts_all_diverge_fails_and_the_loop_goes_on():
    task = NanAfterAWhile()
    config = ControllerConfig(horizon=0.2, max_num_traces=0)
    controller = Controller(config, task, MPPI(MPPIConfig(num_rollouts=8, sigma=0.01), 1))
    with controller:
        # all push hard
        controller.optimizer.sample_control_knots = lambda nominal: np.ones((8, *nominal.shape))
        loop = ClosedLoop(controller, MujocoSystem.from_task(task, seed=0))
        reading = loop.restart()
        # the plan before (none yet: the warm start) stays in force
        assert loop.plan(reading) is None
        assert loop.failed_updates == 1 and isinstance(loop.last_failure, DivergedDynamicsError)
        assert "in all 8 rollouts" in str(loop.last_failure)
        assert np.isfinite(loop.serve(reading.time)).all()


def test_the_plant_is_seeded_noisy_and_resets_on_nan():
    task = UserPendulum()
    task.process_noise = np.array([0.0, 0.01])
    plants = [MujocoSystem.from_task(task, seed=5) for _ in range(2)]
    for plant in plants:
        plant.process_noise[:] = [0.0, 0.01]
        for _ in range(10):
            plant.step()
    assert np.array_equal(plants[0].read_state().state, plants[1].read_state().state)
    assert plants[0].read_state().time == pytest.approx(0.2)
    quiet = DynamicsSystem(UserPendulum(), process_noise=0.0)
    quiet.dynamics_task.state = np.array([1.0, 0.0])
    quiet.step()
    assert np.array_equal(
        quiet.read_state().state,
        quiet.dynamics_task.dynamics(np.array([[1.0, 0.0]]), np.zeros((1, 1)), 0.02)[0],
    )
    nan_plant = DynamicsSystem(NanAfterAWhile())
    nan_plant.apply(np.array([1.0]))
    with pytest.raises(
        SimulationDiverged,
        match=r"^NanAfterAWhile.dynamics gave a "
        r"non-finite state at t=0.000 s; reset",
    ):
        nan_plant.step()
    assert np.isfinite(nan_plant.read_state().state).all()


def test_latency_compensation_predicts_on_the_task_s_own_dynamics():
    from judo.core.reading import SystemState
    from judo.loop.timing import LatencyPredictor

    task = UserPendulum()
    reading = SystemState(np.array([2.0, 0.5]), 1.0, {})
    predicted = LatencyPredictor(task).predict_reading(
        reading, 0.1, lambda t, state: np.array([0.3])
    )
    x = np.array([[2.0, 0.5]])
    for _ in range(5):
        x = task.dynamics(x, np.array([[0.3]]), 0.02)
    assert np.array_equal(predicted.state, x[0])
    assert predicted.time == pytest.approx(1.1)


@pytest.mark.parametrize("name", sorted(get_registered_optimizers()))
def test_every_optimizer_plans_on_a_dynamics_task(name):
    optimizer_cls, config_cls = get_registered_optimizers()[name]
    task = UserPendulum()
    with Controller(
        ControllerConfig(horizon=0.3), task, optimizer_cls(config_cls(num_rollouts=8), 1)
    ) as controller:
        for k in range(3):
            controller.update_action(np.array([np.pi, 0.0]), 0.05 * k)
        assert np.isfinite(controller.rewards).all() and controller.rewards.shape == (8,)
        assert controller.action(0.1).shape == (1,)


def test_bad_task_definitions_are_one_line_errors():
    class Backwards(UserPendulum):
        def __init__(self) -> None:
            DynamicsTask.__init__(self, nx=2, control_range=[[1.0, -1.0]], dt=0.02)

    class BadScene(UserPendulum):
        scene_xml = "<geom type='nothing'/>"

    with pytest.raises(
        ConfigError,
        match=r"^Backwards: control_range rows must "
        r"be \[low, high\] with low <= high",
    ):
        Backwards()
    with pytest.raises(
        ModelLoadError,
        match=r"^BadScene: could not compile "
        r"its scene_xml and robot_xml: ",
    ) as err:
        BadScene()
    assert "\n" not in str(err.value)
