"""What a user asks of the app, checked at once: the App's settings before anything is built, then
the commands the GUI, a notebook or a script give a running app, from any thread.

`check_app_settings` refuses a bad duration, rollout-thread count, seed or System-call limit with a
one-line ConfigError before the App builds anything. `Commands` carries the commands out. Each
command validates at once (raising UnknownNameError, ConfigError or JudoError) and only queues its
request in the app's state (`judo.runtime.app_state`); the plant runner and the planner runner carry
it out at the top of their next iteration. `App` (`judo.runtime.app`) owns one, its public
`commands`: `app.commands.pause()`. The GUI reaches them through the command port
(`judo.runtime.command_port.CommandPort`).
"""

import math
from typing import Any

import numpy as np

from judo.core.commandline.boundary import MAX_WORKERS
from judo.core.configuration.config import Config, check_seed, with_updates
from judo.core.configuration.registry import (
    CONFIG_KINDS,
    ConfigKind,
    lookup_task,
    make_estimator,
)
from judo.core.errors import ConfigError, JudoError
from judo.core.estimator import EstimatorConfig
from judo.evaluation.sensing import check_estimator
from judo.loop.system import System
from judo.runtime.app_state import AppState
from judo.runtime.exchange import MAX_CYCLE_SECONDS, cycle_seconds
from judo.runtime.session import ConfigSet, SessionMaker
from judo.runtime.status import Reports


def check_app_settings(
    duration: float | None,
    num_workers: int | None,
    seed: int | None,
    system_call_limit: float,
    system: System | None,
    observe: str,
) -> None:
    """Raise ConfigError, saying what is wrong and what is valid, for a duration, rollout-thread
    count (at most MAX_WORKERS), seed or System-call limit out of range, or rehearsed sensing
    (`observe` not "state") asked of a user's `system`."""
    if duration is not None and not 0 < duration < math.inf:
        raise ConfigError(
            "duration must be a positive, finite number of seconds of sim time (or None to run "
            f"until stopped), got {duration}"
        )
    if num_workers is not None and not (
        isinstance(num_workers, int) and 1 <= num_workers <= MAX_WORKERS
    ):
        raise ConfigError(
            f"num_workers must be an integer from 1 to {MAX_WORKERS} (or None: one per core), got "
            f"{num_workers!r}"
        )
    check_seed(seed)
    if not 0 < system_call_limit < math.inf:
        raise ConfigError(
            "system_call_limit must be a positive, finite number of seconds, got "
            f"{system_call_limit}"
        )
    if system is not None and observe != "state":
        raise ConfigError(
            f"observe={observe!r} rehearses sensing on the app's own simulation; your System "
            "chooses what it measures (return SystemState.sensors, state None), so leave observe "
            "at 'state'"
        )


class Commands:
    """Config edits, pause and resume, resets, goal moves and switches (see `judo.runtime.app.App`).

    Args:
        state: the app's state, where every command queues its request.
        reports: the status line.
        maker: how the app builds sessions: the user's System (which stays for the whole run), the
            policy, the defaults.
    """

    def __init__(self, *, state: AppState, reports: Reports, maker: SessionMaker) -> None:
        self._state, self._reports, self._maker = state, reports, maker
        self._user_system = maker.user_system

    def update_config(
        self,
        kind: ConfigKind,
        updates: dict[str, Any],
        *,
        generation: int | None = None,
        from_gui: bool = False,
    ) -> Config:
        """Validate `updates` ({field: value}) to the `kind` config and queue it for the next cycle.

        Returns the new config. Raises UnknownNameError or ConfigError, keeping the previous config,
        if a field does not exist, a value is invalid, or the configs would not work together (e.g.
        num_rollouts 0, a horizon shorter than one timestep), or the edit would grow a planning
        cycle past an estimated MAX_CYCLE_SECONDS (`judo.runtime.exchange`). An edit that resizes a
        late cycle cancels it. `generation` (from `session`) refuses an edit made for a session that
        has since been replaced.
        """
        if kind not in CONFIG_KINDS:
            raise ConfigError(f"config kind must be one of {list(CONFIG_KINDS)}, got {kind!r}")
        state = self._state
        with state.lock:
            session = state.session
            if generation is not None and generation != session.generation:
                raise ConfigError(
                    "the task or optimizer changed since this edit was made; it was not applied"
                )
            planner = session.controller
            if kind not in planner.config_kinds:
                raise ConfigError(
                    f"a policy drives {session.task_name}: it has no {kind} config; choose "
                    "an optimizer to plan with MPC"
                )
            current = state.configs.get(kind)
            updated = with_updates(current, updates)
            candidate = state.configs.with_config(kind, updated)
            planner.check_configs(candidate.as_dict())  # refused here, not at the next cycle
            resized = self._check_cycle_cost(updates, candidate)
            if resized and state.cycle is not None and state.cycle.late():
                state.cancel_cycle("the planning cycle was resized")
            state.accept_config(kind, updated, from_gui=from_gui)
            task = session.controller.task
        if (
            kind == "controller"
            and getattr(updated, "max_plan_age", 1) == 0
            and getattr(current, "max_plan_age", 0) != 0
        ):
            self._reports.report(
                "max_plan_age 0 turns the watchdog off: a stalled planner's last plan is "
                "served however old it is",
                "warning",
            )
        rate = getattr(updated, "control_freq", None)
        if kind == "controller" and rate is not None and rate < type(task).min_control_freq:
            self._reports.report(
                f"control_freq {rate:g} Hz is below the {type(task).min_control_freq:g} Hz "
                f"that {type(task).__name__}'s "
                "defaults need (docs/tasks.md); expect it to fail",
                "warning",
            )
        return updated

    def _check_cycle_cost(self, updates: dict[str, Any], candidate: ConfigSet) -> bool:
        """True if the `candidate` configs change the size of a planning cycle (the planner's
        `cycle_size`; a policy rolls nothing out); ConfigError if they grow it beyond an estimated
        MAX_CYCLE_SECONDS (a smaller cycle is always accepted). Under the lock."""
        state = self._state
        planner = state.session.controller
        before, after = (
            planner.cycle_size(state.configs.as_dict()),
            planner.cycle_size(candidate.as_dict()),
        )
        if after is None:
            return False
        seconds = cycle_seconds(state.step_cost, after, candidate.controller)
        if seconds > MAX_CYCLE_SECONDS and (before is None or after.total > before.total):
            edit = ", ".join(f"{name} = {value}" for name, value in updates.items())
            raise ConfigError(
                f"{edit} would make a planning cycle of about {seconds:.0f} s (num_rollouts "
                "x num_randomizations x "
                f"iterations x horizon steps: {after}); expected at most "
                f"{MAX_CYCLE_SECONDS:g} s: lower "
                "num_rollouts, num_randomizations, max_opt_iters, iterations_per_second or "
                "the horizon"
            )
        return after != before

    def update_estimator_config(
        self, updates: dict[str, Any], *, generation: int | None = None, from_gui: bool = False
    ) -> EstimatorConfig:
        """Validate `updates` ({field: value}) to the running estimator's config and use it from its
        next update. Returns the new config. Raises ConfigError, keeping the config before, for an
        unknown field or a bad value, and JudoError when no estimator runs or the session changed
        (`generation`)."""
        state = self._state
        with state.lock:
            session = state.session
            if generation is not None and generation != session.generation:
                raise ConfigError(
                    "the task or optimizer changed since this edit was made; it was not applied"
                )
            estimator = session.closed_loop.estimator
            if estimator is None:
                raise JudoError(
                    "no estimator runs: the app plans from the plant's full state; start it with "
                    "estimator='ekf' (or observe='sensors') to have one"
                )
            updated = with_updates(estimator.config, updates)
            assert isinstance(updated, EstimatorConfig)
            # used from its next update
            state.accept_estimator_config(estimator, updated, from_gui=from_gui)
        return updated

    def reset_configs(self) -> None:
        """Put every config back to the task's registered defaults (at the next cycle)."""
        state = self._state
        with state.lock:
            session = state.session
            state.reset_configs(
                self._maker.default_configs(session.task_name, session.optimizer_name)
            )
        self._reports.report("configs reset to the defaults")

    def pause(self) -> None:
        """Freeze the plant and the planner (a paused simulation keeps its time)."""
        self._state.pause()
        self._reports.report("paused")

    def resume(self) -> None:
        """Undo `pause()`."""
        self._state.resume()
        self._reports.report(self._reports.running())

    def reset_task(self) -> None:
        """Reset the plant to its start state and forget the plan."""
        # the plan is forgotten once the plant's reset worked
        self._state.request_reset(from_user=True)

    def move_goal(self, index: int, position: np.ndarray, quat: np.ndarray | None = None) -> None:
        """Move mocap body `index` (a goal) to `position` (3,), and turn it to `quat` (4,) wxyz if
        given, before the plant's next step, through the System's `move_goal` (the simulated plant
        writes its MjData).

        The planner sees it with the next state (the reading's metadata carries the mocap poses).
        Raises JudoError for a user's System without `move_goal`, or an index the model does not
        have.
        """
        session = self._state.session
        plant = session.simulated
        if plant is None and type(session.system).move_goal is System.move_goal:
            raise JudoError(
                f"cannot move goal {index}: your {type(session.system).__name__} has no "
                "System.move_goal"
            )
        nmocap = (
            session.controller.task.model.nmocap if plant is None else plant.task.sim_model.nmocap
        )
        if not 0 <= index < nmocap:
            raise JudoError(f"goal index must be in [0, {nmocap}), got {index}")
        try:
            moved = np.array(position, dtype=float).reshape(3)
            turn = None if quat is None else np.array(quat, dtype=float).reshape(4)
        except (TypeError, ValueError) as err:
            raise JudoError(
                f"goal {index}: a position needs 3 numbers and a quat 4: {err}"
            ) from None
        if not np.isfinite(moved).all() or (
            turn is not None and not (np.isfinite(turn).all() and turn.any())
        ):
            raise JudoError(
                f"goal {index} not moved: position {moved.tolist()} and quat must be finite "
                "(quat not 0)"
            )
        self._state.request_goal_move(index, moved, turn)

    def switch_task(self, task: str) -> None:
        """Use the registered task `task` from the next cycle, with its default configs."""
        lookup_task(task)
        running = self._state.session.task_name
        if self._user_system is not None and task != running:
            raise JudoError(
                f"cannot switch to task {task!r}: the app drives your own System, which is "
                f"{running!r}; start a new App for another task"
            )
        self._state.request_switch(task=task)

    def switch_estimator(self, estimator: str | None) -> None:
        """Run the registered estimator `estimator` (None: none, planning from full-state readings
        as they are) from the next cycle, keeping the plant running: restarted from the next
        reading, with its registered defaults (its live config when it is the one running). Raises
        UnknownNameError for an unregistered name, JudoError when the plant's readings lack what it
        needs (a full state)."""
        state = self._state
        session = state.session
        # tried on the plant's latest reading (its own thread may be reading it now)
        if estimator is not None:
            latest = session.closed_loop.raw_reading or session.system.read_state()
            check_estimator(estimator, make_estimator(estimator, session.controller.task), latest)
        with state.lock:
            raw = session.closed_loop.raw_reading
            if estimator is None and raw is not None and raw.state is None:
                raise JudoError(
                    "cannot plan without an estimator: the plant measures only sensors "
                    "(state None); choose "
                    "an estimator that fuses them, e.g. 'ekf'"
                )
            state.request_estimator(
                estimator, rebuild=not (estimator is None and session.estimator_name is None)
            )

    def switch_optimizer(self, optimizer: str) -> None:
        """Use the registered optimizer `optimizer` from the next cycle, keeping the plant
        running."""
        # an optimizer, or the policy (the GUI's "policy")
        self._maker.check_choice(self._state.session.task_name, optimizer)
        self._state.request_switch(optimizer=optimizer)
