"""Tasks whose rollouts are their own dynamics: a vectorized numpy step instead of MuJoCo physics.

A `DynamicsTask` writes `dynamics(states (N, nx), controls (N, nu), dt) -> (N, nx)`;
`DynamicsRollout` rolls a batch out as T vectorized calls behind the same `RolloutBackend` interface
as the MuJoCo pool, so the Controller's loop, every optimizer, the splines, evaluate, tune and
collect stay as they are. The task answers for itself: its `rollout_backend` is this one, its
`simulator` "dynamics" (the plant `DynamicsSystem`), its `predict_step` its own dynamics, and the
GUI draws its `drawn_model`.

The rest of judo passes states around as a MuJoCo model's [qpos, qvel]. A DynamicsTask therefore
carries a small generated model (`carrier_xml`): ceil(nx / 2) slide joints, no contacts, no gravity,
one motor per control holding its limits, the timestep `dt`. Its [qpos, qvel] is the task's state x,
with one trailing zero when nx is odd; the plant (`DynamicsSystem`, in judo.loop.system) keeps x
there, so logs, datasets and the GUI read it as any other task's state. MuJoCo never steps that
model.
"""

import math
from abc import abstractmethod
from collections.abc import Sequence
from typing import Any, ClassVar

import mujoco
import numpy as np

from judo.core.errors import ConfigError, JudoError, ModelLoadError, NonFiniteRewardError
from judo.core.model import STATE_SPEC
from judo.core.rollouts.backend import RolloutBackend
from judo.core.rollouts.factory import make_rollout_backend
from judo.core.sensors import measured_layout
from judo.core.task import ConfigT, Task


class DynamicsError(JudoError):
    """A DynamicsTask's `dynamics` returned the wrong shape, or non-finite states in every
    rollout."""


class DivergedDynamicsError(DynamicsError, NonFiniteRewardError):
    """Every rollout of a cycle diverged (NaN or infinite states): like every rollout scoring -inf,
    a failed update that keeps the plan before (the closed loop counts it), not the end of an
    episode."""


def state_size(nx: int) -> int:
    """nq + nv of the carrier model of an nx-state task: nx rounded up to even."""
    return nx + nx % 2


def carrier_xml(
    name: str,
    nx: int,
    control_range: np.ndarray,
    dt: float,
    scene_xml: str = "",
    num_traces: int = 0,
) -> str:
    """The MJCF text of the model carrying an nx-state task with (nu, 2) `control_range` and
    timestep `dt`.

    ceil(nx / 2) slide joints (qpos holds x[:k], qvel x[k:]), each on its own body without contacts,
    one motor per control on joint i % k with its limits (unlimited where a bound is infinite), the
    task's `scene_xml` (worldbody elements: static geoms, mocap goals) and `num_traces` "trace"
    framepos sensors, whose values the backend fills from `DynamicsTask.trace_points`.
    """
    joints = state_size(nx) // 2
    joint_lines = "\n".join(
        f'    <body name="state{i}"><joint name="x{i}" type="slide" axis="1 0 0"/>'
        '<geom type="sphere" size="0.01" mass="1" contype="0" conaffinity="0" group="5"/></body>'
        for i in range(joints)
    )
    motors = []
    for i, (low, high) in enumerate(np.asarray(control_range, dtype=float)):
        limits = (
            f'ctrllimited="true" ctrlrange="{float(low)!r} {float(high)!r}"'
            if np.isfinite([low, high]).all()
            else ""
        )
        motors.append(f'    <motor name="u{i}" joint="x{i % joints}" {limits}/>')
    sites = "".join(f'<site name="trace_site{k}"/>' for k in range(num_traces))
    sensors = "".join(
        f'<framepos name="trace{k}" objtype="site" objname="trace_site{k}"/>'
        for k in range(num_traces)
    )
    return f"""<mujoco model="{name}">
  <option timestep="{dt!r}" gravity="0 0 0" integrator="Euler"/>
  <worldbody>
    {sites}
    {scene_xml}
{joint_lines}
  </worldbody>
  <actuator>
{chr(10).join(motors)}
  </actuator>
  <sensor>{sensors}</sensor>
</mujoco>
"""


def drawing_xml(name: str, scene_xml: str, robot_xml: str) -> str:
    """The MJCF text of the model the GUI draws a DynamicsTask with: its scene (the carrier's mocap
    bodies in the same order) and its robot, whose joints `DynamicsTask.draw_qpos` sets."""
    return f"""<mujoco model="{name}">
  <visual><global offwidth="640" offheight="480"/></visual>
  <worldbody>
    <light pos="0 0 5" dir="0 0 -1"/>
    {scene_xml}
    {robot_xml}
  </worldbody>
</mujoco>
"""


class DynamicsTask(Task[ConfigT]):
    """A control problem on dynamics you write: `dynamics` steps a batch of states, `reward` scores
    rollouts.

    Subclass it as `class MyTask(DynamicsTask[MyConfig])`, call `super().__init__(nx, control_range,
    dt)` and implement `dynamics` and `reward` (the signature of every task; `states` is (N, T, nx),
    with one extra zero column when nx is odd, and `sensors` (N, T, 3 * num_traces)
    the `trace_points`). Goals reach `reward` as any task's: mocap bodies of `scene_xml`,
    in `system_metadata` (judo.core.model.mocap_pose reads them).
    `initial_state` sets where the plant starts (zeros by default; draw from `self.rng` for a random
    start).

    Drawing in the GUI: `scene_xml` (worldbody MJCF: a floor, obstacles, mocap goals the GUI lets
    you drag, which the plant publishes as any task's) and `robot_xml` (the robot's bodies with
    their joints) build `draw_model`;
    `draw_qpos` maps states to its qpos. `trace_points` gives the points the GUI traces along the
    rollouts.

    Attributes:
        nx: the state's length.
        model: the generated carrier model (`carrier_xml`), whose [qpos, qvel] is the state x; its
            actuators hold the control limits and its timestep is `dt`.
        process_noise: (nx,) standard deviation of the Gaussian noise the simulated plant adds to
            the state after each step (zeros: none); the planning rollouts never add it.
    """

    scene_xml: ClassVar[str] = ""
    """Worldbody MJCF elements in both the carrier and the drawing model: a floor, static obstacles,
    mocap goals."""
    robot_xml: ClassVar[str] = ""
    """Worldbody MJCF of the robot as drawn (bodies with joints); its qpos comes from
    `draw_qpos`."""
    num_traces: ClassVar[int] = 0
    """How many points `trace_points` gives per state (the GUI draws each one's path along the
    rollouts)."""

    def __init__(
        self, nx: int, control_range: Sequence[Sequence[float]] | np.ndarray, dt: float
    ) -> None:
        control_range = np.asarray(control_range, dtype=float)
        if not (isinstance(nx, int) and nx > 0):
            raise ConfigError(f"{type(self).__name__}: nx must be a positive integer, got {nx!r}")
        if control_range.ndim != 2 or control_range.shape[1] != 2 or not len(control_range):
            raise ConfigError(
                f"{type(self).__name__}: control_range must be (nu, 2) [low, high] rows, got "
                f"shape {control_range.shape}"
            )
        if not (control_range[:, 0] <= control_range[:, 1]).all():
            raise ConfigError(
                f"{type(self).__name__}: control_range rows must be [low, high] with low <= "
                "high, got "
                f"{control_range.tolist()}"
            )
        if not (math.isfinite(dt) and dt > 0):
            raise ConfigError(
                f"{type(self).__name__}: dt must be a positive number of seconds, got {dt}"
            )
        self.nx = nx
        name = type(self).__name__
        try:
            self.model = mujoco.MjModel.from_xml_string(
                carrier_xml(name, nx, control_range, dt, self.scene_xml, self.num_traces)
            )
            self.draw_model = mujoco.MjModel.from_xml_string(
                drawing_xml(name, self.scene_xml, self.robot_xml)
            )
            """The model the GUI draws (`drawing_xml`): the scene and the robot."""
        except ValueError as err:
            reason = " ".join(str(err).split())
            raise ModelLoadError(
                f"{name}: could not compile its scene_xml and robot_xml: {reason}"
            ) from None
        self.sim_model = self.model
        # what Task.__init__ sets, which this one replaces
        self.model_overrides: dict[str, dict[str, Any]] = {}
        self.plant_overrides: dict[str, dict[str, Any]] = {}
        self.measured = self.sim_measured = measured_layout(self.model, (), type(self).__name__)
        self.data = mujoco.MjData(self.model)
        self.config = self.config_cls()  # pyright: ignore[reportAttributeAccessIssue]
        self.rng = np.random.default_rng()
        self.process_noise = np.zeros(nx)

    @abstractmethod
    def dynamics(self, states: np.ndarray, controls: np.ndarray, dt: float) -> np.ndarray:
        """One step of every row: (N, nx) states and (N, nu) controls (within their limits) to (N,
        nx) states `dt` seconds later. Vectorized numpy; return a new array (the inputs are the
        backend's)."""

    # the simulated plant steps `dynamics` (judo.loop.system.DynamicsSystem)
    simulator: ClassVar[str] = "dynamics"

    def draw_qpos(self, states: np.ndarray) -> np.ndarray:
        """(B, draw_model.nq) the drawn robot's joint positions at (B, nx) states; none by
        default."""
        return np.zeros((len(states), self.draw_model.nq))

    def drawn_model(self) -> mujoco.MjModel:
        """`draw_model`: the scene and the robot, which the GUI draws instead of the carrier."""
        return self.draw_model

    def drawn_qpos(self, state: np.ndarray) -> np.ndarray:
        """(draw_model.nq,) `draw_qpos` at the (nq + nv,) carrier `state`'s x."""
        return np.asarray(
            self.draw_qpos(np.asarray(state, dtype=float)[None, : self.nx]), dtype=float
        )[0]

    def rollout_backend(self, name: str) -> "DynamicsRollout":
        """`DynamicsRollout` on this task, asked for by the default backend name "cpu" (ConfigError
        for another)."""
        if name != "cpu":
            raise ConfigError(
                f"{type(self).__name__} rolls out its own dynamics, which run on the host: "
                "expected backend 'cpu' "
                f"(the default), got {name!r}"
            )
        return DynamicsRollout(self)

    def predict_step(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """One step of `dynamics` from `data`'s [qpos, qvel] under its ctrl; time advances by
        `model`'s timestep."""
        state = np.concatenate([data.qpos, data.qvel])
        state[: self.nx] = self.step_checked(state[None, : self.nx], data.ctrl[None].copy())[0]
        nq = model.nq
        data.qpos[:], data.qvel[:], data.time = (
            state[:nq],
            state[nq:],
            data.time + model.opt.timestep,
        )

    def trace_points(self, states: np.ndarray) -> np.ndarray:
        """(..., num_traces, 3) world points the GUI traces, at (..., nx) states; none by
        default."""
        return np.zeros((*states.shape[:-1], self.num_traces, 3))

    def initial_state(self) -> np.ndarray:
        """The (nx,) state the plant starts from on `reset`; zeros by default. Draw from `self.rng`
        to randomize."""
        return np.zeros(self.nx)

    @property
    def state(self) -> np.ndarray:
        """The plant's (nx,) state, read from `data` (a copy)."""
        return np.concatenate([self.data.qpos, self.data.qvel])[: self.nx]

    @state.setter
    def state(self, x: np.ndarray) -> None:
        padded = np.zeros(self.model.nq + self.model.nv)
        padded[: self.nx] = x
        self.data.qpos[:], self.data.qvel[:] = padded[: self.model.nq], padded[self.model.nq :]

    def reset(self) -> None:
        """Put the plant at `initial_state()`, time 0."""
        mujoco.mj_resetData(self.model, self.data)
        self.state = x = np.asarray(self.initial_state(), dtype=float)
        self.data.sensordata[:] = self.trace_points(x).ravel()

    def safe_action(self, state: np.ndarray) -> np.ndarray:
        """Zero controls clamped to their limits; override it for what brings your system to
        rest."""
        low, high = self.actuator_ctrlrange.T
        return np.clip(np.zeros(self.nu), low, high)

    def step_checked(self, states: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """`dynamics(states, controls, dt)` as a float array, or DynamicsError naming the task when
        it is not (N, nx). (N, nx) states, (N, nu) controls."""
        out = self.dynamics(states, controls, self.dt)
        try:
            out = np.asarray(out, dtype=float)
        except (TypeError, ValueError) as err:
            raise DynamicsError(
                f"{type(self).__name__}.dynamics must return (N, nx) numbers, got "
                f"{type(out).__name__} ({err})"
            ) from None
        if out.shape != states.shape:
            raise DynamicsError(
                f"{type(self).__name__}.dynamics returned shape {out.shape}, expected "
                f"{states.shape} = (N, nx)"
            )
        return out


class DynamicsRollout(RolloutBackend):
    """Rolls a DynamicsTask's batch out as T vectorized `dynamics` calls, one per step, on the
    calling thread.

    Outputs are preallocated once per batch shape. Rows whose state becomes NaN or infinite are
    flagged in
    `diverged`, which the Controller scores -inf: a diverged rollout never wins.
    """

    name = "dynamics"
    diverged: np.ndarray

    def __init__(self, task: DynamicsTask) -> None:
        self.task = task
        self.model = task.model
        self.num_workers = 1
        self._state_size = mujoco.mj_stateSize(task.model, STATE_SPEC)
        self._states = np.zeros((0, 0, self._state_size))
        self._sensors = np.zeros((0, 0, 0))
        self.diverged = np.zeros(0, dtype=bool)

    def rollout(
        self, initial_state: np.ndarray, controls: np.ndarray, mocap: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Every (num_rollouts, T, nu) control sequence from the full-physics `initial_state` of the
        carrier model (time, then x). Returns states (num_rollouts, T, nstate) with time in column 0
        and x in columns 1 to nx, and sensors (num_rollouts, T, 3 * num_traces), the `trace_points`.
        `mocap` is ignored: the reward reads goals from its system metadata. Raises DynamicsError
        for a wrong output shape, or when every row has diverged."""
        task, nx = self.task, self.task.nx
        num_rollouts, num_steps, _ = controls.shape
        if self._states.shape[:2] != (num_rollouts, num_steps):
            self._states = np.zeros((num_rollouts, num_steps, self._state_size))
            self._sensors = np.zeros((num_rollouts, num_steps, self.model.nsensordata))
            self.diverged = np.zeros(num_rollouts, dtype=bool)
        states = self._states
        states[:, :, 0] = initial_state[0] + task.dt * np.arange(1, num_steps + 1)
        x = np.repeat(initial_state[None, 1 : 1 + nx], num_rollouts, axis=0)
        diverged = self.diverged
        diverged[:] = False
        for t in range(num_steps):
            x = task.step_checked(x, controls[:, t])
            states[:, t, 1 : 1 + nx] = x
            # a later step may map NaN or inf back to finite numbers
            diverged |= ~np.isfinite(x).all(axis=1)
        if task.num_traces:
            self._sensors[:] = task.trace_points(states[:, :, 1 : 1 + nx]).reshape(
                self._sensors.shape
            )
        if diverged.all():
            raise DivergedDynamicsError(
                f"{type(task).__name__}.dynamics gave NaN or infinite states in all "
                f"{num_rollouts} rollouts; "
                "expected finite states (check the step for divisions by zero or a too large dt)"
            )
        return states, self._sensors


def drawn_model(task: Task) -> mujoco.MjModel:
    """The model the GUI draws `task` with: the task's `drawn_model()` (a DynamicsTask's
    `draw_model`)."""
    return task.drawn_model()


def drawn_qpos(task: Task, state: np.ndarray | None) -> np.ndarray:
    """(drawn_model(task).nq,) the drawn qpos at the (nq + nv,) `state` (the task's `drawn_qpos`);
    the drawn model's qpos0 for a reading without a state."""
    return task.drawn_model().qpos0.copy() if state is None else task.drawn_qpos(state)


def task_rollout_backend(task: Task, name: str, num_workers: int | None) -> RolloutBackend:
    """The backend a Controller rolls `task` out on: the task's own (`Task.rollout_backend`, a
    DynamicsTask's `DynamicsRollout`), else `make_rollout_backend(name, task.model,
    num_workers)`."""
    own = task.rollout_backend(name)
    return own if own is not None else make_rollout_backend(name, task.model, num_workers)
