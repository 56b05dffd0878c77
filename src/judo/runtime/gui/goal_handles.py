"""Drag handles for goals: a viser transform control on every mocap body and every `np_1d_field`
with a `vis_name`.

A field's handle moves only along the axes the field has (x; x and y; x, y and z). Dragging calls
`on_field(name, value)` with the field's new (n,) array, or `on_mocap(index, position, wxyz)` with a
mocap body's new (3,) position and (4,) orientation (mocap goals turn too); the caller turns those
into a config edit or a plant command. While no page drags a handle, `update` keeps it on the goal,
wherever the goal moved.

A drag's start, moves and end reach the handle's callback as coroutines, which viser runs on its
event loop as each message arrives, in order: the start marks the handle as dragged (so `update`
leaves it where the page puts it) before a move's pose is read, right after viser applied it. The
app's command is then made from one worker thread, in the same order. (A plain callback goes to
viser's thread pool, where start, moves and end race each other and `update`: under load a move
could read the handle already put back on the old goal, and the goal did not move.)
"""

import logging
from collections.abc import Callable, Coroutine
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import mujoco
import numpy as np
import viser

from judo.core.configuration.config import Config
from judo.core.configuration.fields import array_field_spec

logger = logging.getLogger("judo.gui")

HANDLE_SCALE = 0.2
"""Handle size as a fraction of the model's extent (within HANDLE_SIZES), so it suits a hand or a
field."""
HANDLE_SIZES = (0.06, 0.4)
"""Smallest and largest handle, in metres."""
MOCAP_HANDLE_FRACTION = 0.7
"""A mocap goal's handle reaches at most this fraction of its geoms' half-size, so it never hides
the goal..."""
MIN_HANDLE_FRACTION = 0.05
"""...but never less than this fraction of the model's extent (about the camera's framing): a goal
sphere of a few centimetres on a robot a metre long got a handle of 15 pixels, which a mouse could
not grab."""
HANDLE_LINE_WIDTH = 5.0
"""Width of a handle's arrows and rings in pixels (viser's default 2.5 is hard to hit)."""

_commands = ThreadPoolExecutor(max_workers=1, thread_name_prefix="judo-goal-drag")
"""Makes the app's commands for drags, one at a time in the order the drag messages came."""


def mocap_handle_size(model: mujoco.MjModel, body: int, scale: float) -> float:
    """The handle size for mocap `body`: `scale`, shrunk to MOCAP_HANDLE_FRACTION of the half-size
    of the body's largest geom (its bounding box), so a goal cube stays visible around its handle,
    and grown to MIN_HANDLE_FRACTION of the model's extent, so a small goal's handle can still be
    grabbed."""
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body]
    if not geoms:
        return scale
    half = float(model.geom_aabb[geoms, 3:].max())
    return max(
        min(scale, MOCAP_HANDLE_FRACTION * half), MIN_HANDLE_FRACTION * float(model.stat.extent)
    )


class GoalHandles:
    """Transform controls under `/goals` for the goals of `model` and of configs like `config`."""

    def __init__(
        self,
        scene: viser.SceneApi,
        model: mujoco.MjModel,
        config: Config,
        on_field: Callable[[str, np.ndarray], None],
        on_mocap: Callable[[int, np.ndarray, np.ndarray], None],
    ) -> None:
        self.scene, self._on_field, self._on_mocap = scene, on_field, on_mocap
        self.controls: dict[str, Any] = {}
        self._dragging: set[str] = set()
        scale = float(np.clip(HANDLE_SCALE * float(model.stat.extent), *HANDLE_SIZES))
        for body in range(1, model.nbody):
            index = int(model.body_mocapid[body])
            if index >= 0:
                name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"mocap_{index}"
                size = mocap_handle_size(model, body, scale)
                control = self._add(
                    f"mocap/{name}", size, (True, True, True), model.body_pos[body], turns=True
                )
                control.on_update(
                    _on_loop(
                        lambda event, i=index, key=f"mocap/{name}": self._dragged_mocap(
                            event, key, i
                        )
                    )
                )
        for field_name, value in vars(config).items():
            spec = array_field_spec(type(config), field_name)
            if spec is None or spec.vis_name is None:
                continue
            axes = min(len(value), 3)
            position = np.zeros(3)
            position[:axes] = np.asarray(value, dtype=float)[:axes]
            key = f"field/{field_name}"
            control = self._add(key, scale, (axes > 0, axes > 1, axes > 2), position)
            control.on_update(
                _on_loop(lambda event, f=field_name, key=key: self._dragged_field(event, key, f))
            )
        self._config = config

    def update(
        self, config: Config, mocap_pos: np.ndarray | None, mocap_quat: np.ndarray | None = None
    ) -> None:
        """Put every handle no page is dragging on its goal: `config`'s fields, (nmocap, 3)
        `mocap_pos` and (nmocap, 4) `mocap_quat`."""
        self._config = config
        for key, control in self.controls.items():
            if key in self._dragging:
                continue
            kind, name = key.split("/", 1)
            if kind == "field":
                value = np.asarray(getattr(config, name), dtype=float)[:3]
                position = np.array(control.position, dtype=float)
                position[: len(value)] = value
            elif mocap_pos is not None:
                index = self._mocap_index(key)
                position = mocap_pos[index]
                if mocap_quat is not None and not np.allclose(mocap_quat[index], control.wxyz):
                    control.wxyz = mocap_quat[index]
            else:
                continue
            if not np.allclose(position, control.position):
                control.position = position

    def remove(self) -> None:
        """Take the handles out of the scene."""
        self.scene.remove_by_name("/goals")

    def _add(
        self,
        key: str,
        scale: float,
        axes: tuple[bool, bool, bool],
        position: np.ndarray,
        turns: bool = False,
    ) -> Any:
        control = self.scene.add_transform_controls(
            f"/goals/{key}",
            scale=scale,
            line_width=HANDLE_LINE_WIDTH,
            active_axes=axes,
            disable_rotations=not turns,
            disable_sliders=not all(axes[:2]),
            depth_test=False,
            position=np.asarray(position, dtype=float),
        )
        self.controls[key] = control
        return control

    def _track(self, event: Any, key: str) -> bool:
        """Note drags starting and ending; True for a move a page made."""
        if event.phase == "start":
            self._dragging.add(key)
        elif event.phase == "end":
            self._dragging.discard(key)
        return event.client_id is not None

    def _dragged_field(self, event: Any, key: str, field_name: str) -> None:
        if not self._track(event, key):
            return
        value = np.array(getattr(self._config, field_name), dtype=float)
        axes = min(len(value), 3)
        value[:axes] = np.asarray(event.target.position, dtype=float)[:axes]
        _command(self._on_field, field_name, value)

    def _dragged_mocap(self, event: Any, key: str, index: int) -> None:
        if self._track(event, key):
            position, wxyz = (
                np.array(event.target.position, dtype=float),
                np.array(event.target.wxyz, dtype=float),
            )
            _command(self._on_mocap, index, position, wxyz)

    def _mocap_index(self, key: str) -> int:
        return [k for k in self.controls if k.startswith("mocap/")].index(key)


def _command(call: Callable[..., None], *args: Any) -> None:
    """Run `call(*args)` on the drag worker after the commands before it; an exception it raises is
    logged."""

    def log_failure(done: Future) -> None:
        if done.exception() is not None:
            logger.error("a goal drag's command failed", exc_info=done.exception())

    _commands.submit(call, *args).add_done_callback(log_failure)


def _on_loop(handle: Callable[[Any], None]) -> Callable[[Any], Coroutine[Any, Any, None]]:
    """`handle` as a coroutine function, which viser runs on its event loop as each drag message
    arrives (see above)."""

    async def on_update(event: Any) -> None:
        handle(event)

    return on_update
