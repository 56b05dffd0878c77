"""The config panels the GUI builds for a session: one per config kind (controller, optimizer, task)
and one for its estimator, each titled, ranged and trimmed for the session, whose edits go to the
app's commands and are reported on the status line.
"""

from dataclasses import fields
from typing import Any

import numpy as np
import viser

from judo.core.configuration.config import Config
from judo.core.configuration.fields import SliderRange
from judo.core.configuration.registry import ConfigKind
from judo.runtime.command_port import AppPort
from judo.runtime.gui.config_panel import ConfigPanel, EditFn

MAX_ROLLOUTS_BY_BACKEND = {"warp": 8192}
"""Upper end of the num_rollouts slider on a rollout backend, by the backend's name (a GPU rolls out
thousands of samples per cycle); a backend not named here keeps the optimizer config's own range."""


def config_panels(
    gui: viser.GuiApi, app: AppPort, session: Any, configs: dict[str, Config]
) -> dict[str, ConfigPanel]:
    """{kind: panel} of `session`'s `configs` (`app.configs()`), in their order."""
    titles = {
        "controller": "Controller",
        "optimizer": f"Optimizer: {session.optimizer_name}",
        "task": f"Task: {session.task_name}",
    }
    # a policy: none
    max_rollouts = MAX_ROLLOUTS_BY_BACKEND.get(session.controller.backend_name or "")
    ranges = (
        {"optimizer": {"num_rollouts": SliderRange(1, max_rollouts, 1)}} if max_rollouts else {}
    )
    return {
        kind: ConfigPanel(
            gui,
            titles[kind],
            config,
            _editor(app, kind, session.generation),
            10 * order,
            ranges.get(kind),
            on_refused=lambda why: app.report(f"edit refused: {why}", "warning"),
            hidden=hidden_fields(session, kind, config),
            kind=kind,
        )
        for order, (kind, config) in enumerate(configs.items(), start=1)
    }


def estimator_panel(gui: viser.GuiApi, app: AppPort, session: Any) -> ConfigPanel | None:
    """The panel of `session`'s estimator's config, or None without an estimator."""
    estimator = session.closed_loop.estimator
    if estimator is None:
        return None
    generation = session.generation

    def edit(updates: dict[str, Any]) -> Config:
        config = app.commands.update_estimator_config(updates, generation=generation, from_gui=True)
        shown = ", ".join(f"{name} = {_shown(getattr(config, name))}" for name in updates)
        app.report(f"estimator config: {shown}")
        return config

    return ConfigPanel(
        gui,
        f"Estimator: {session.estimator_name}",
        estimator.config,
        edit,
        40,
        on_refused=lambda why: app.report(f"edit refused: {why}", "warning"),
        kind="estimator",
    )


def hidden_fields(session: Any, kind: ConfigKind, config: Config) -> tuple[str, ...]:
    """The fields of `session`'s `kind` config that get no widget: while a policy drives, the
    controller fields only an optimizer uses; without a proposal policy, policy_samples (every value
    but 0 would be refused)."""
    if kind != "controller":
        return ()
    used = session.controller.controller_fields  # the planner says which it uses
    return tuple(f.name for f in fields(config) if f.name not in used)


def _editor(app: AppPort, kind: ConfigKind, generation: int) -> EditFn:
    def edit(updates: dict[str, Any]) -> Config:
        config = app.commands.update_config(kind, updates, generation=generation, from_gui=True)
        shown = ", ".join(f"{name} = {_shown(getattr(config, name))}" for name in updates)
        app.report(f"{kind} config: {shown}")
        return config

    return edit


def _shown(value: Any) -> str:
    """A config value as the status line shows it: floats to 4 significant digits, arrays as
    lists."""
    if isinstance(value, np.ndarray):
        return "[" + ", ".join(_shown(float(v)) for v in value) + "]"
    return f"{value:.4g}" if isinstance(value, float) else str(value)
