"""The Task contract: a MuJoCo model plus a reward over batches of rollouts."""

import typing
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Generic, Protocol, TypeVar, cast

import mujoco
import numpy as np

from judo.core.configuration.config import Config
from judo.core.errors import ModelLoadError
from judo.core.model import holding_ctrl, load_model, model_mocap_poses, object_id
from judo.core.sensors import MeasuredLayout, measured_layout

SENSOR, JOINT = mujoco.mjtObj.mjOBJ_SENSOR, mujoco.mjtObj.mjOBJ_JOINT


class LowLevelCommands(Protocol):
    """What `Task.low_level()` returns (a `judo.core.rollouts.low_level.LowLevel`): a policy that
    turns the C planned commands (each within its row of `command_range`) into ctrl; `plant(model)`
    is its side on the simulated plant."""

    command_range: np.ndarray

    @property
    def command_size(self) -> int: ...

    def plant(self, model: mujoco.MjModel) -> Any: ...


@dataclass
class TaskConfig(Config):
    """Base of every task's config: reward weights and goals, read by `Task.reward` each update."""


@dataclass
class EpisodeLog:
    """A closed-loop episode of the plant, one row per plant step, for `Task.metrics`.

    Attributes:
        times: (S,) plant time after each step.
        states: (S, nq + nv) [qpos, qvel] after each step.
        controls: (S, nu) control applied during each step.
        sensors: (S, nsensordata) plant sensor values after each step.
    """

    times: np.ndarray
    states: np.ndarray
    controls: np.ndarray
    sensors: np.ndarray


ConfigT = TypeVar("ConfigT", bound=TaskConfig)


class Task(ABC, Generic[ConfigT]):
    """A control problem: a planning model, a plant model, and a reward to maximise.

    Subclass it as `class MyTask(Task[MyConfig])` and implement `reward`; every other hook has a
    no-op default. Attributes:
        model: the MjModel the controller plans with.
        sim_model: the MjModel of the plant (the same object unless `sim_model_path` differs); it
            must have the same nq, nv, nu and mocap bodies as `model`.
        data: the plant's MjData (on `sim_model`), used only when this instance is the simulated
            plant (`MujocoSystem`): the simulator steps it; `reset`, `pre_sim_step` and
            `post_sim_step` may write to it. The controller never reads it: planning hooks get the
            state they need as arguments.
        config: this task's config, an instance of the class named in `Task[...]`.
        rng: the np.random.Generator for resets and goal sampling; replace it to seed an episode.
        measured / sim_measured: where `measured_sensors` lie in the planning / plant model's
            sensordata.
    """

    config_cls: ClassVar[type[TaskConfig]] = TaskConfig
    lower_is_better: ClassVar[tuple[str, ...]] = ()
    """Names of the `metrics` that are better lower (errors, distances, times, drops); every other
    metric, and evaluate's "mean_reward", is better higher (`tune` reads the direction here)."""
    check_latency_ms: ClassVar[float] = 25.0
    """The fixed planning latency (ms) the task's defaults are checked under, besides none (a
    `tune`'s default conditions and benchmarks/defaults_under_conditions.py); slower tasks check a
    larger one."""
    min_control_freq: ClassVar[float] = 20.0
    """The slowest replanning rate (Hz) the task's defaults are checked at and hold at
    (docs/tasks.md): 20 Hz, what a loaded laptop reaches, unless the task is too unstable for it;
    the slow rate of a `tune`'s default conditions."""
    focus_body: ClassVar[str | None] = None
    """The body the GUI's camera follows while the task runs; None: the first body with a free
    joint, if any."""
    measured_sensors: ClassVar[tuple[str, ...]] = ()
    """Names of the MJCF sensors a robot running this task would have (encoders, a camera's pose, an
    IMU), in the order a System's `SystemState.sensors` holds their values. Trace sensors are never
    measured. Checked against both models when the task is built; `measured` says where the values
    lie."""
    default_estimator: ClassVar[str] = "ekf"
    """The registered estimator that fuses `measured_sensors` when none is named (`--estimator`):
    with `--observe sensors`, or under a System whose readings have no full state; read through
    `judo.core.estimator` (`estimator_in_force`, `default_estimator_name`). A class attribute: the
    task's TOML holds only config fields."""
    recorded_metadata: ClassVar[tuple[str, ...]] = ()
    """Keys of the system metadata (`get_sim_metadata`) that the task's `reward` or
    `policy_observation` reads, each a number or a fixed-shape array of numbers: `collect` keeps
    every step's value (`obs/metadata/KEY`) and `distill` gives it back to `policy_observation`.
    "mocap_pos" is kept for every task with mocap bodies (`obs/mocap_pos`) and is not listed
    here."""
    simulator: ClassVar[str] = "mujoco"
    """The simulated plant the task needs: "mujoco" steps `sim_model`, "dynamics" a DynamicsTask's
    own dynamics."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Take `config_cls` from `Task[ConfigT]` among the class's own bases. A subclass of a task
        inherits its parent's `config_cls`, or names its own: `config_cls = MyConfig` in its body.
        Checks the keys of `recorded_metadata` (TypeError)."""
        super().__init_subclass__(**kwargs)
        for base in cls.__dict__.get("__orig_bases__", ()):
            args = typing.get_args(base)
            origin = typing.get_origin(base)  # Task[C], or a generic subclass's (DynamicsTask[C])
            if isinstance(origin, type) and issubclass(origin, Task) and args:
                if isinstance(args[0], type):
                    cls.config_cls = args[0]
        keys = cls.recorded_metadata
        names_keys = isinstance(keys, tuple) and all(isinstance(k, str) for k in keys)
        if not names_keys or not all(k and "/" not in k for k in keys):
            raise TypeError(
                f"{cls.__name__}.recorded_metadata must be a tuple of key names without '/', got "
                f"{keys!r}"
            )
        if "mocap_pos" in keys:
            raise TypeError(
                f"{cls.__name__}.recorded_metadata lists 'mocap_pos', which is always kept: "
                "leave it out"
            )

    def __init__(self, model_path: str | Path, sim_model_path: str | Path | None = None) -> None:
        self.model = load_model(model_path)
        if sim_model_path is None or Path(sim_model_path).resolve() == Path(model_path).resolve():
            self.sim_model = self.model
        else:
            self.sim_model = load_model(sim_model_path)
        for size in ("nq", "nv", "nu", "nmocap"):
            plant, planning = getattr(self.sim_model, size), getattr(self.model, size)
            if plant != planning:
                raise ModelLoadError(
                    f"plant model {sim_model_path} has {size}={plant} but the planning model "
                    f"{model_path} has {size}={planning}; they must match"
                )
        self.model_overrides: dict[str, dict[str, Any]] = {}
        """MjModel fields set on the planning model by element name (configuration/model_overrides);
        {}: the MJCF's."""
        self.plant_overrides: dict[str, dict[str, Any]] = {}
        """MjModel fields set on the plant model (`sim_model`), which every plant built from this
        task gets."""
        owner = type(self).__name__
        self.measured: MeasuredLayout = measured_layout(self.model, self.measured_sensors, owner)
        """Where `measured_sensors` lie in the planning model's sensordata."""
        self.sim_measured: MeasuredLayout = (
            self.measured
            if self.sim_model is self.model
            else measured_layout(self.sim_model, self.measured_sensors, owner)
        )
        """Where `measured_sensors` lie in the plant model's sensordata."""
        self.data = mujoco.MjData(self.sim_model)
        # config_cls is the class named in Task[ConfigT] (__init_subclass__): a ClassVar can't say
        self.config: ConfigT = cast(ConfigT, self.config_cls())
        self.rng = np.random.default_rng()

    @abstractmethod
    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: ConfigT,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """Score each rollout; higher is better.

        Args:
            states: (num_rollouts, T, nq + nv), [qpos, qvel] after each step. Under randomized
                models the batch holds num_randomizations * num_rollouts rows (block r: every
                sequence under model r) and the reward must score each row alone, as any reward
                does.
            sensors: (num_rollouts, T, nsensordata), sensor readings after each step.
            controls: (num_rollouts, T, nu), the control applied at each step; under a low-level
                policy (`low_level`), the (num_rollouts, T, C) commands planned for each step
                instead.
            config: the snapshot of this task's config taken for this update; read weights here.
            system_metadata: what the system published with the state (e.g. mocap goal poses).
        Returns:
            (num_rollouts,) rewards. NaN counts as -inf: it never wins.

        On the warp backend a large batch is scored in blocks of rows, several at once on host
        threads (core/rollouts/parallel_reward.py): read the arguments and the task's constants, and
        write nothing shared.
        """

    # Hooks, each with a no-op default; override the ones the task needs. Helpers below them.
    def reset(self) -> None:
        """Put the plant (`self.data`) in a start state; the default is the model's keyframe 0 or
        qpos0."""
        if self.sim_model.nkey:
            mujoco.mj_resetDataKeyframe(self.sim_model, self.data, 0)
        else:
            mujoco.mj_resetData(self.sim_model, self.data)
        mujoco.mj_forward(self.sim_model, self.data)

    def low_level(self) -> LowLevelCommands | None:
        """A low-level policy to plan over (judo.core.rollouts.low_level), or None (the default):
        plan the actuators. With one, the optimizer plans its C commands (`command_size`,
        `command_range`), every rollout and the plant run the policy every k physics steps to turn
        them into ctrl, and `reward` gets the commands as `controls`. Return the same object on
        every call (build it once, in `__init__`)."""
        return None

    # What a task with its own dynamics (judo.core.rollouts.dynamics.DynamicsTask) answers else:
    def rollout_backend(self, name: str) -> Any:
        """The task's own RolloutBackend, or None (the default): backend `name` on the model."""
        return None

    def predict_step(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Step `data` on `model` under `data.ctrl` (the latency model's prediction): mj_step."""
        mujoco.mj_step(model, data)

    def drawn_model(self) -> mujoco.MjModel:
        """The model the GUI draws the task with: the planning model."""
        return self.model

    def drawn_qpos(self, state: np.ndarray) -> np.ndarray:
        """(drawn_model().nq,) the drawn qpos at the (nq + nv,) `state`: its qpos."""
        return state[: self.model.nq]

    def pre_rollout(self, state: np.ndarray) -> None:
        """Called once per planning cycle with the (nq + nv,) state, before any rollout."""

    def post_rollout(
        self, states: np.ndarray, sensors: np.ndarray, controls: np.ndarray, rewards: np.ndarray
    ) -> None:
        """Called after each optimizer iteration with the rollouts' arrays and (num_rollouts,)
        rewards. Under randomized models (num_randomizations > 1) the arrays are the rollouts on the
        planning model and the rewards are each sequence's rewards over all models, reduced by the
        risk measure."""

    def pre_sim_step(self) -> None:
        """Called by the simulator before each plant step, e.g. to resample a reached goal."""

    def post_sim_step(self) -> None:
        """Called by the simulator after each plant step, e.g. to reset a dropped object."""

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Perturb `model`, a private copy of the planning model, in place, drawing from `rng`.
        Called when the controller plans under several models (`ControllerConfig.num_randomizations`
        > 1), once per randomized model per redraw. Scale what the real system gets wrong
        (frictions, masses, dampings, gains; helpers in `judo.core.rollouts.randomize`); never
        change sizes. The default does nothing."""

    def get_sim_metadata(self) -> dict[str, Any]:
        """Extra values the simulator publishes with the state; passed on to `reward`."""
        return {}

    def readout(self, system_metadata: dict[str, Any]) -> str | None:
        """One line the GUI shows under its figures, from the plant's latest metadata (e.g. the
        command a task tracks); None (the default) shows nothing."""
        return None

    def success(self, metrics: dict[str, float]) -> bool | None:
        """Whether an episode with these `metrics` counts as a success (`collect --success-only`);
        None without a rule. The default reads a "success" metric (true above 0.5), if any."""
        return metrics["success"] > 0.5 if "success" in metrics else None

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """Success figures of a finished episode for `evaluate`, e.g. {"final_distance": 0.02}; none
        by default. Goal-reaching tasks report "goals_reached" and "goals_per_minute" (counted in
        the plant task's `pre_sim_step`)."""
        return {}

    def policy_observation(
        self,
        states: np.ndarray,
        sensors: np.ndarray | None = None,
        system_metadata: dict[str, Any] | None = None,
        previous_actions: np.ndarray | None = None,
    ) -> np.ndarray:
        """What a policy sees (judo.Policy): a batch of observations, vectorized over the batch.

        Args:
            states: (B, nq + nv) [qpos, qvel].
            sensors: (B, nsensordata) the planning model's sensor values at those states, or None
                (none to give).
            system_metadata: what the system published with the state (e.g. "mocap_pos" (nmocap,
                3)), or None; judo.core.model.mocap_pose reads a mocap pose from it, falling back to
                the model's own.
            previous_actions: (B, nu) the action each row was served last, or None where there is
                none.
        Returns:
            (B, O) float observations; the default is the states themselves, O = nq + nv. Override
            it to give a policy what it was trained on, e.g. `np.concatenate([states, sensors[:,
            self.measured.columns]], axis=1)`.
        """
        return np.asarray(states, dtype=float)

    def policy_observation_size(self) -> int:
        """O, the length of one `policy_observation`: the hook called on one zero row (and the
        model's mocap poses)."""
        model, metadata = self.model, model_mocap_poses(self.model)
        rows = (np.zeros((1, model.nq + model.nv)), np.zeros((1, model.nsensordata)))
        return int(np.shape(self.policy_observation(*rows, metadata, np.zeros((1, self.nu))))[-1])

    def default_proposal_policy(self) -> Any:
        """The judo.Policy a controller given no proposal policy takes its `policy_samples`
        candidates from (judo.core.policies.proposals); None (the default): none."""
        return None

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        """The (command_size,) control the first plan holds at every knot, from the (nq + nv,) plant
        `state` it starts from; zeros by default (the form without `state` warns, deprecated)."""
        return np.zeros(self.command_size)

    def feedback_cost(self) -> tuple[np.ndarray, np.ndarray]:
        """The tracking cost of the feedback gains (`ControllerConfig.feedback`): (2 nv,) weights on
        the deviation [dq, dv] from the nominal rollout (dq in the tangent space) and (nu,) weights
        on the control correction. By default 1 per position, 0.1 per velocity, 0.1 / (half its
        range)^2 per control (unbounded: half range 1): 0.1 rad costs as much as a third of a half
        range (stiffer gains did worse at 5 Hz: docs/tasks.md)."""
        low, high = self.actuator_ctrlrange.T
        half = 0.5 * (high - low)
        half = np.where(np.isfinite(half) & (half > 0), half, 1.0)
        return np.concatenate([np.ones(self.model.nv), np.full(self.model.nv, 0.1)]), 0.1 / half**2

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """The (command_size,) control that brings the plant to rest from the (nq + nv,) `state`:
        what the watchdog serves when the plan in force is too old, and what `System.halt` applies
        by default. The default sets motor, force and velocity actuators to 0 and holds position
        actuators at their joint's current position, clamped to the ctrlrange (override it for a
        gripper that must keep its grip, a drone that must hover); under a low-level policy, each
        command's zero clamped to its range."""
        if self.low_level() is not None:
            low, high = self.command_range.T
            return np.clip(np.zeros(self.command_size), low, high)
        low, high = self.actuator_ctrlrange.T
        return np.clip(holding_ctrl(self.model, state), low, high)

    @property
    def nu(self) -> int:
        """Number of actuators."""
        return self.model.nu

    @property
    def dt(self) -> float:
        """Planning model timestep in seconds."""
        return float(self.model.opt.timestep)

    @property
    def actuator_ctrlrange(self) -> np.ndarray:
        """(nu, 2) control limits, [-inf, inf] for unlimited actuators. A copy; the model is
        untouched."""
        limited = self.model.actuator_ctrllimited.astype(bool)
        ranges = np.tile([-np.inf, np.inf], (self.nu, 1))
        ranges[limited] = self.model.actuator_ctrlrange[limited]
        return ranges

    @property
    def command_size(self) -> int:
        """What the optimizer plans and the System is served per step: `nu` actuators' ctrl, or
        under a low-level policy (`low_level`) its C commands."""
        low_level = self.low_level()
        return self.nu if low_level is None else low_level.command_size

    @property
    def command_range(self) -> np.ndarray:
        """(command_size, 2) the limits the plan is clamped to: `actuator_ctrlrange`, or under a
        low-level policy its `command_range`. A copy."""
        low_level = self.low_level()
        return self.actuator_ctrlrange if low_level is None else low_level.command_range.copy()

    def get_sensor_start_index(self, sensor_name: str) -> int:
        """Column of `sensor_name`'s first value in the sensors array."""
        m = self.model
        return int(m.sensor_adr[object_id(m, SENSOR, m.nsensor, sensor_name, "sensor")])

    def get_joint_position_start_index(self, joint_name: str) -> int:
        """Column of `joint_name`'s first qpos entry in the states array."""
        m = self.model
        return int(m.jnt_qposadr[object_id(m, JOINT, m.njnt, joint_name, "joint")])

    def get_joint_velocity_start_index(self, joint_name: str) -> int:
        """Column of `joint_name`'s first qvel entry in the states array (qvel follows qpos)."""
        m = self.model
        return int(m.nq + m.jnt_dofadr[object_id(m, JOINT, m.njnt, joint_name, "joint")])


TaskT = TypeVar("TaskT", bound=Task)


def new_task(task_cls: type[TaskT]) -> TaskT:
    """A new `task_cls()`. A registered task class builds its own models and so takes no arguments
    (what `register_task` asks of it), while the Task base it is typed by takes the model paths:
    hence the cast."""
    return cast(Callable[[], TaskT], task_cls)()
