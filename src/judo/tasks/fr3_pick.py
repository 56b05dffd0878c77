"""FR3 pick and place: a 7-DoF Franka-style arm with a parallel gripper lifts a 4 cm cube off the
table, carries it to a goal and sets it down there, through lift, move, place and done phases."""

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import mujoco
import numpy as np

from judo.core.configuration.fields import slider
from judo.core.rollouts.randomize import (
    body_id,
    contact_geom_ids,
    scale_body_mass,
    scale_geom_friction,
)
from judo.core.task import EpisodeLog, Task, TaskConfig

MODEL_PATH = Path(__file__).parent / "models" / "fr3_pick.xml"

PHASES = ("lift", "move", "place", "done")
"""lift: reach, grasp and raise the object; move: carry it above the goal; place: lower it onto the
goal; done: let go and back off upwards."""
LIFT, MOVE, PLACE, DONE = range(len(PHASES))

ARM_JOINTS = tuple(f"joint{i}" for i in range(1, 8))


@slider("w_reach", 0.0, 20.0, 0.1)
@slider("w_lift", 0.0, 50.0, 0.1)
@slider("w_carry", 0.0, 50.0, 0.1)
@slider("w_grip", 0.0, 10.0, 0.01)
@slider("w_release", 0.0, 10.0, 0.01)
@slider("w_upright", 0.0, 10.0, 0.01)
@slider("w_press", 0.0, 10.0, 0.01)
@slider("lift_height", 0.05, 0.4, 0.01)
@dataclass
class FR3PickConfig(TaskConfig):
    """FR3 pick-and-place reward weights; each phase uses the terms that matter to it."""

    w_reach: float = 5.0
    """Weight on the gripper centre's distance (m) to the object (lift: coming down from above it;
    move, place) or, once placed, to a point `lift_height` above it, scaled by how far the gripper
    is open."""
    w_lift: float = 10.0
    """Weight on the object's height error (m) to `lift_height` above the table (lift, move)."""
    w_carry: float = 10.0
    """Weight on the object's distance (m) to the goal: horizontal in move, full in place and
    done."""
    w_grip: float = 0.2
    """Weight on the gripper being closed near the object and open away from it (0..1 each)."""
    w_release: float = 2.0
    """Weight on the gripper being open once the cube is placed (done); above w_reach * lift_height,
    so letting go comes before backing off."""
    w_upright: float = 1.0
    """Weight on the gripper pointing straight down (1 + z of its axis, 0..2) with its fingers
    closing square to the cube's faces (sin^2 of twice the yaw error, 0..1)."""
    w_press: float = 2.0
    """Weight on the gap (rad, summed over the arm's joints) between the joint targets and the joint
    angles (done). Gravity is compensated, so a lasting gap means the arm presses on something:
    without this term the targets of a hand resting on the table after the release creep below it,
    no small change of them lifts the hand, and the open fingers slowly push the cube off the
    goal."""
    lift_height: float = 0.15
    """How high (m) above its resting height the object is carried."""


class FR3Pick(Task[FR3PickConfig]):
    """State [7 arm joint angles, 2 finger openings, cube position and quaternion, their
    velocities]; controls are 7 joint position targets (ctrlrange = joint range) and the gripper
    opening target (0 closed, 1 open).

    The goal is the mocap body "goal". The plant task keeps the phase (`PHASES`) in `pre_sim_step`
    from the object's state and publishes it as system_metadata["phase"]; the reward uses that
    phase's terms.
    """

    lower_is_better = ("final_distance", "time_to_place")
    focus_body = "object"
    measured_sensors = (
        *(f"joint{i}_pos" for i in range(1, 8)),
        "finger_left_pos",
        "object_pos",
        "object_quat",
    )
    check_latency_ms = 50.0
    recorded_metadata = ("phase",)  # the reward's terms depend on it: collect keeps each step's

    lift_fraction: ClassVar[float] = 0.6
    """The object counts as lifted above this fraction of `lift_height`."""
    place_radius: ClassVar[float] = 0.02
    """Horizontal distance (m) to the goal at which a carried object is lowered (move -> place)."""
    placed_radius: ClassVar[float] = 0.015
    """Distance (m) of the object to the goal at which it counts as placed (place -> done)."""
    success_radius: ClassVar[float] = 0.03
    """Distance (m) of the object to the goal at the end of an episode that counts as success."""
    approach_height: ClassVar[float] = 0.06
    """Height (m) above the object from which the gripper comes down onto it."""
    near_object: ClassVar[float] = 0.02
    """Length scale (m) of the gripper-object distance at which the gripper should close."""
    hold_radius: ClassVar[float] = 0.035
    """Largest gripper-object distance (m) at which a carried object still counts as held."""
    min_hold_opening: ClassVar[float] = 0.015
    """Smallest finger opening (m, per finger) with the 2 cm half-wide cube between the fingers;
    fingers closed further hold nothing."""

    def __init__(
        self, model_path: str | Path = MODEL_PATH, sim_model_path: str | Path | None = None
    ) -> None:
        super().__init__(model_path, sim_model_path)
        self._arm_qpos = np.array(
            [self.get_joint_position_start_index(name) for name in ARM_JOINTS]
        )
        self._finger_qpos = self.get_joint_position_start_index("finger_left")
        self._object_qpos = self.get_joint_position_start_index("object")
        self._object_qvel = self.get_joint_velocity_start_index("object") - self.model.nq
        self._tcp = self.get_sensor_start_index("trace_tcp")
        self._object = self.get_sensor_start_index("trace_object")
        self._goal = self.get_sensor_start_index("goal_pos")
        self._zaxis = self.get_sensor_start_index("tcp_zaxis")
        self._finger_axis = self.get_sensor_start_index("finger_axis")
        self._object_xaxis = self.get_sensor_start_index("object_xaxis")
        self._home_key = mujoco.mj_name2id(self.sim_model, mujoco.mjtObj.mjOBJ_KEY, "home")
        self.rest_height = float(self.sim_model.key_qpos[self._home_key][self._object_qpos + 2])
        self.max_opening = float(self.model.jnt_range[self.model.joint("finger_left").id, 1])
        self.phase = LIFT
        self.max_phase = LIFT
        self.time_placed = float("nan")
        self.reset()

    def reward(
        self,
        states: np.ndarray,
        sensors: np.ndarray,
        controls: np.ndarray,
        config: FR3PickConfig,
        system_metadata: dict[str, Any] | None = None,
    ) -> np.ndarray:
        """Minus the time-averaged cost of the current phase's terms, (num_rollouts,)."""
        phase = int((system_metadata or {}).get("phase", self.phase))
        tcp = sensors[..., self._tcp : self._tcp + 3]
        obj = sensors[..., self._object : self._object + 3]
        goal = sensors[..., self._goal : self._goal + 3]
        # 0 closed .. 1 open. Clipped: fingers pressed onto the table can be forced past their
        # range, and that must not pay more than fully open (the planner would learn to jam them
        # to "let go").
        opening = np.clip(states[..., self._finger_qpos] / self.max_opening, 0.0, 1.0)
        reach = np.linalg.norm(tcp - obj, axis=-1)
        height_error = np.abs(obj[..., 2] - (self.rest_height + config.lift_height))
        # Upright: the gripper points down (1 + z of its axis) and its fingers close square to the
        # cube's faces (sin^2 of twice the yaw between the finger axis and the cube's x axis).
        finger_xy = sensors[..., self._finger_axis : self._finger_axis + 2]
        cube_x = sensors[..., self._object_xaxis : self._object_xaxis + 2]
        cube_y = np.stack([-cube_x[..., 1], cube_x[..., 0]], axis=-1)
        square = 4.0 * np.square(np.sum(finger_xy * cube_x, -1) * np.sum(finger_xy * cube_y, -1))
        cost = config.w_upright * (1.0 + sensors[..., self._zaxis + 2] + square)
        if phase == LIFT:
            # Approach from above: sideways and vertical distances to the object, plus a penalty for
            # being below a floor that hovers over it, by nothing within 1 cm sideways (the open
            # fingers clear the cube by 2 cm) rising to `approach_height` at 3 cm, so the fingers
            # come down around the cube instead of knocking it over.
            sideways = np.linalg.norm(tcp[..., :2] - obj[..., :2], axis=-1)
            above = tcp[..., 2] - obj[..., 2]
            floor = self.approach_height * np.clip((sideways - 0.01) / 0.02, 0.0, 1.0)
            approach = sideways + np.abs(above) + 2.0 * np.maximum(floor - above, 0.0)
            near = np.exp(-np.square(reach / self.near_object))
            cost += config.w_reach * approach + config.w_lift * height_error
            cost += config.w_grip * (near * opening + (1.0 - near) * (1.0 - opening))
        elif phase == MOVE:
            cost += config.w_reach * reach + config.w_lift * height_error + config.w_grip * opening
            cost += config.w_carry * np.linalg.norm(obj[..., :2] - goal[..., :2], axis=-1)
        elif phase == PLACE:
            cost += config.w_reach * reach + config.w_grip * opening
            cost += config.w_carry * np.linalg.norm(obj - goal, axis=-1)
        else:
            # Let go, then back off: the pull to a point `lift_height` above the cube grows as the
            # gripper opens, and `w_release` outweighs it, so the gripper opens before it rises. The
            # press term keeps the joint targets near the joints, so that rising is a small change
            # of plan.
            above = obj + np.array([0.0, 0.0, config.lift_height])
            cost += config.w_release * (1.0 - opening)
            cost += config.w_reach * opening * np.linalg.norm(tcp - above, axis=-1)
            cost += config.w_carry * np.linalg.norm(obj - goal, axis=-1)
            cost += config.w_press * np.abs(controls[..., :7] - states[..., self._arm_qpos]).sum(-1)
        return -cost.mean(-1)

    def reset(self) -> None:
        """Arm at "home" with the gripper open; object and goal on random, separate spots of the
        table."""
        mujoco.mj_resetDataKeyframe(self.sim_model, self.data, self._home_key)
        object_xy = self.random_spot()
        goal_xy = self.random_spot()
        while np.linalg.norm(goal_xy - object_xy) < 0.15:
            goal_xy = self.random_spot()
        self.data.qpos[self._object_qpos : self._object_qpos + 2] = object_xy
        self.data.mocap_pos[0, :2] = goal_xy
        self.data.mocap_pos[0, 2] = self.rest_height
        mujoco.mj_forward(self.sim_model, self.data)
        self.phase = LIFT
        self.max_phase = LIFT
        self.time_placed = float("nan")

    def random_spot(self) -> np.ndarray:
        """(2,) a random x, y in the arm's workspace on the table, from `self.rng`."""
        return self.rng.uniform([0.4, -0.25], [0.6, 0.25])

    def holds_object(self, tcp: np.ndarray, obj: np.ndarray, opening: float) -> bool:
        """Whether the gripper centre `tcp` (3,) is next to the object `obj` (3,) with the fingers
        held apart by it (`opening` in m per finger), i.e. the object is between the fingers."""
        return (
            float(np.linalg.norm(tcp - obj)) < self.hold_radius and opening > self.min_hold_opening
        )

    def next_phase(
        self, phase: int, obj: np.ndarray, goal: np.ndarray, lift_height: float, held: bool
    ) -> int:
        """The phase that follows `phase` given the object's and goal's (3,) positions and whether
        the gripper holds the object (`holds_object`). A loose object in the air is left to land
        first: the grasp test is noisy while the fingers close or the arm swings, and a false
        "dropped" costs a regrasp."""
        lifted = obj[2] - self.rest_height > self.lift_fraction * lift_height
        on_table = obj[2] - self.rest_height < 0.01
        horizontal = float(np.linalg.norm(obj[:2] - goal[:2]))
        distance = float(np.linalg.norm(obj - goal))
        if phase == LIFT and lifted:
            return MOVE
        if phase == PLACE and distance < self.placed_radius:
            return DONE
        if (
            phase in (MOVE, PLACE)
            and on_table
            and (not held or horizontal > 2.5 * self.place_radius)
        ):
            # dropped on the way, or lying loose under the gripper: open up and grasp it again
            return LIFT
        if phase == MOVE and horizontal < self.place_radius:
            return PLACE
        if phase == DONE and distance > 2.5 * self.placed_radius:
            return LIFT  # knocked off the goal
        return phase

    def pre_sim_step(self) -> None:
        """Advance the phase from the object's state; note when the object was first placed."""
        obj = self.data.qpos[self._object_qpos : self._object_qpos + 3]
        tcp = self.data.sensordata[self._tcp : self._tcp + 3]
        held = self.holds_object(tcp, obj, float(self.data.qpos[self._finger_qpos]))
        self.phase = self.next_phase(
            self.phase, obj, self.data.mocap_pos[0], self.config.lift_height, held
        )
        self.max_phase = max(self.max_phase, self.phase)
        if self.phase == DONE and np.isnan(self.time_placed):
            self.time_placed = float(self.data.time)

    def get_sim_metadata(self) -> dict[str, Any]:
        """{"phase": index into PHASES}, for the planner's reward."""
        return {"phase": self.phase}

    def randomize_model(self, model: mujoco.MjModel, rng: np.random.Generator) -> None:
        """Each contact geom's sliding friction x U[0.6, 1.25] (its own draw), the object's mass and
        inertia x U[0.75, 1.5]."""
        scale_geom_friction(model, contact_geom_ids(model), 0.6, 1.25, rng)
        scale_body_mass(model, body_id(model, "object"), 0.75, 1.5, rng)

    def metrics(self, log: EpisodeLog) -> dict[str, float]:
        """success (object within `success_radius` of the goal at the end), its final distance, the
        furthest phase reached (index into PHASES) and the time it was first placed (the episode's
        length if never, so that means over episodes stay finite)."""
        final = log.sensors[-1]
        distance = np.linalg.norm(
            final[self._object : self._object + 3] - final[self._goal : self._goal + 3]
        )
        placed = self.time_placed if not np.isnan(self.time_placed) else float(log.times[-1])
        return {
            "success": float(distance < self.success_radius),
            "final_distance": float(distance),
            "phase_reached": float(self.max_phase),
            "time_to_place": placed,
        }

    def optimizer_warm_start(self, state: np.ndarray) -> np.ndarray:
        """(8,) the arm's joint angles in the (nq + nv,) plant `state` as targets, with the gripper
        open."""
        return np.append(state[self._arm_qpos], 1.0)
