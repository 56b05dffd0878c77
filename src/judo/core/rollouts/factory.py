"""`make_rollout_backend`: a rollout backend by its name ("cpu", "warp"), its module imported when
asked for.

The backends' modules (core/rollouts/rollout.py, core/rollouts/warp_rollout.py) import the interface
(core/rollouts/backend.py), never this module; this module names them by dotted path
(`BACKEND_CLASSES`), so `import judo` never imports warp.
"""

import importlib
from collections.abc import Callable
from typing import cast

import mujoco

from judo.core.errors import UnknownNameError
from judo.core.rollouts.backend import ROLLOUT_BACKENDS, RolloutBackend

BACKEND_CLASSES: dict[str, str] = {
    "cpu": "judo.core.rollouts.rollout.RolloutPool",
    "warp": "judo.core.rollouts.warp_rollout.WarpRollout",
}
"""Each name in ROLLOUT_BACKENDS and the dotted path of its class, imported when the backend is
asked for."""


def check_rollout_backend(name: str) -> None:
    """Raise UnknownNameError for a name not in ROLLOUT_BACKENDS, and MissingExtraError when the
    backend's optional extra is not installed; builds nothing."""
    backend_class(name)


def backend_class(name: str) -> type[RolloutBackend]:
    """The class of the rollout backend called `name`, importing its module (and so its extra) now.

    Raises UnknownNameError for a name not in ROLLOUT_BACKENDS and MissingExtraError (from the
    module's import) when the backend's extra is not installed."""
    if name not in ROLLOUT_BACKENDS:
        raise UnknownNameError("rollout backend", name, ROLLOUT_BACKENDS)
    module, _, attribute = BACKEND_CLASSES[name].rpartition(".")
    return getattr(importlib.import_module(module), attribute)


def make_rollout_backend(
    name: str, model: mujoco.MjModel, num_workers: int | None = None
) -> RolloutBackend:
    """The rollout backend called `name` (one of ROLLOUT_BACKENDS) for `model`.

    `num_workers` sets the CPU pool's threads (one per core by default); a GPU backend runs every
    rollout on its device and takes no worker count. Raises UnknownNameError for an unknown name,
    MissingExtraError when "warp" is asked for without the judo-mpc[warp] extra, and
    WarpUnsupportedModelError for a model MuJoCo Warp cannot run.
    """
    # The constructors take different arguments (only the CPU pool's takes num_workers), which
    # RolloutBackend, declaring none, cannot describe: the class is called as a plain callable (a
    # widening cast).
    cls = cast(Callable[..., RolloutBackend], backend_class(name))
    if name == "cpu":
        return cls(model, num_workers)
    return cls(model)
