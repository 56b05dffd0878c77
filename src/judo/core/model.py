"""Loading MJCF models and reading names and sensor layouts out of them (read-only)."""

from pathlib import Path

import mujoco
import numpy as np

from judo.core.errors import ModelLoadError, UnknownNameError

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS


def load_model(path: str | Path) -> mujoco.MjModel:
    """Compile the MJCF file at `path` through MjSpec; raise ModelLoadError naming the path."""
    path = Path(path)
    if not path.is_file():
        raise ModelLoadError(f"MuJoCo model file not found: {path}")
    try:
        # Absolute, because MuJoCo resolves a relative path twice for an <include>d file that itself
        # names a <model> asset file.
        return mujoco.MjSpec.from_file(str(path.resolve())).compile()
    except Exception as err:  # mujoco raises ValueError or its own errors; all mean "bad model"
        raise ModelLoadError(f"could not compile MuJoCo model {path}: {err}") from err


def model_mocap_poses(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """The model's own mocap poses, as a System publishes them: "mocap_pos" (nmocap, 3) and
    "mocap_quat" (nmocap, 4), in mocap index order (each mocap body's pos and quat in the MJCF)."""
    bodies = np.flatnonzero(model.body_mocapid >= 0)
    order = np.argsort(model.body_mocapid[bodies])
    return {
        "mocap_pos": model.body_pos[bodies[order]].copy(),
        "mocap_quat": model.body_quat[bodies[order]].copy(),
    }


def mocap_pose(model: mujoco.MjModel, metadata: dict | None, key: str) -> np.ndarray:
    """`metadata[key]` ("mocap_pos" or "mocap_quat") where `metadata` has it, else the model's own
    poses: (nmocap, 3 or 4), or (B, nmocap, 3 or 4) where the metadata gives one row per batch
    row."""
    if metadata and key in metadata:
        return np.asarray(metadata[key], dtype=float)
    return model_mocap_poses(model)[key]


def object_id(
    model: mujoco.MjModel, obj_type: mujoco.mjtObj, count: int, name: str, kind: str
) -> int:
    """The id of the `obj_type` object `name` in `model`; UnknownNameError (naming it a `kind` and
    listing the model's `count` names of that type) where it has none."""
    index = mujoco.mj_name2id(model, obj_type, name)
    if index < 0:
        raise UnknownNameError(kind, name, [n for n in names(model, obj_type, count) if n])
    return index


def holding_ctrl(model: mujoco.MjModel, state: np.ndarray) -> np.ndarray:
    """(nu,) the ctrl that holds each joint position actuator (a servo: affine bias -kp * q) at its
    joint's position in the (nq + nv,) `state`, divided by its gear; 0 for every other actuator."""
    action = np.zeros(model.nu)
    joint_types = (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT))
    for i in range(model.nu):
        joint = int(model.actuator_trnid[i, 0])
        is_joint = int(model.actuator_trntype[i]) in joint_types
        affine = int(model.actuator_biastype[i]) == int(mujoco.mjtBias.mjBIAS_AFFINE)
        position_servo = affine and model.actuator_biasprm[i, 1] != 0
        if is_joint and position_servo and joint >= 0:
            gear = float(model.actuator_gear[i, 0]) or 1.0
            action[i] = state[model.jnt_qposadr[joint]] / gear
    return action


def names(model: mujoco.MjModel, obj_type: mujoco.mjtObj, count: int) -> list[str]:
    """The names of the `count` objects of `obj_type` in `model`, in id order."""
    return [mujoco.mj_id2name(model, obj_type, i) or "" for i in range(count)]


def trace_sensor_columns(model: mujoco.MjModel) -> np.ndarray:
    """Columns of sensordata holding the 3-D `framepos` sensors whose name contains "trace".

    Returns an int array of shape (3 * num_trace_sensors,), three consecutive columns per sensor.
    """
    columns = [
        np.arange(model.sensor_adr[i], model.sensor_adr[i] + 3)
        for i, name in enumerate(names(model, mujoco.mjtObj.mjOBJ_SENSOR, model.nsensor))
        if "trace" in name and model.sensor_type[i] == mujoco.mjtSensor.mjSENS_FRAMEPOS
    ]
    return np.concatenate(columns) if columns else np.zeros(0, dtype=int)
