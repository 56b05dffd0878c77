"""What a dataset records about the run's settings and models: configs as JSON values, model
hashes."""

import dataclasses
import hashlib
from typing import Any

import mujoco
import numpy as np

from judo.core.configuration.config import Config


def config_dict(config: Config) -> dict[str, Any]:
    """A config's fields as JSON values (arrays as lists)."""
    values = {f.name: getattr(config, f.name) for f in dataclasses.fields(config)}
    return {
        name: value.tolist() if isinstance(value, np.ndarray) else value
        for name, value in values.items()
    }


def model_sha256(model: mujoco.MjModel) -> str:
    """SHA-256 of the compiled model (its MJB bytes): it changes with any edit of the XML or of a
    file it includes."""
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return hashlib.sha256(buffer.tobytes()).hexdigest()
