"""`EpisodeRecorder`: a Recorder that gathers one episode's steps and plans into the dataset's
arrays."""

import dataclasses
from typing import Any

import numpy as np

from judo.core.errors import JudoError
from judo.core.planner_view import AppPlanner, PlannerKind
from judo.core.policies.policy_controller import PolicyController
from judo.core.task import Task
from judo.loop.records import PlanRecord, StepRecord
from judo.recording.dataset import EpisodeArrays


class EpisodeRecorder:
    """Accumulates the StepRecords and PlanRecords of one closed-loop episode (the `Recorder`
    protocol).

    Args:
        nq, nv: sizes of the plant's qpos and qvel, to split each step's (nq + nv,) state (and
            estimate).
        nmocap: the plant's mocap bodies; with any, each step's metadata must hold "mocap_pos"
            (nmocap, 3).
        num_nodes, nu: shape of a plan's knots, for the (0, num_nodes, nu) array of an episode with
            no plan.
        measured_sensors: names of the task's measured sensors, stored beside the steps' measured
            values.
        traces: whether to keep each plan's traces; the closed loop copies them only for a recorder
            whose `wants_traces` is true.
        recorded_metadata: the task's `Task.recorded_metadata`: keys of each step's metadata to
            keep, each a number or an array of one shape throughout; a step without one, or with
            another shape, is an error.
        task_name: the task's name, for those errors.
    """

    def __init__(
        self,
        nq: int,
        nv: int,
        nmocap: int,
        num_nodes: int,
        nu: int,
        measured_sensors: tuple[str, ...] = (),
        traces: bool = False,
        recorded_metadata: tuple[str, ...] = (),
        task_name: str = "the task",
    ) -> None:
        self.nq, self.nv, self.nmocap, self.num_nodes, self.nu = nq, nv, nmocap, num_nodes, nu
        self.measured_sensors = tuple(measured_sensors)
        self.wants_traces = traces
        self.recorded_metadata, self.task_name = tuple(recorded_metadata), task_name
        self.steps: list[StepRecord] = []
        self.plans: list[PlanRecord] = []

    @classmethod
    def for_loop(
        cls, planner: AppPlanner, plant_task: Task, traces: bool = False
    ) -> "EpisodeRecorder":
        """A recorder for the plans of `planner`, where an optimizer plans (PlannerKind.MPC), and
        the plant model (`sim_model`) of `plant_task`."""
        model, optimizer = plant_task.sim_model, planner.optimizer
        assert planner.kind is PlannerKind.MPC and optimizer, (
            "an EpisodeRecorder of the loop records an MPC's plans"
        )
        sizes = (model.nq, model.nv, model.nmocap, optimizer.num_nodes, planner.task.command_size)
        return cls(
            *sizes, tuple(plant_task.measured_sensors), traces, *metadata_settings(plant_task)
        )

    def with_records(self, steps: list[StepRecord], plans: list[PlanRecord]) -> "EpisodeRecorder":
        """A recorder of the same sizes and settings holding `steps` and `plans`."""
        sizes = (self.nq, self.nv, self.nmocap, self.num_nodes, self.nu)
        recorder = EpisodeRecorder(
            *sizes, self.measured_sensors, self.wants_traces, self.recorded_metadata, self.task_name
        )
        recorder.steps, recorder.plans = steps, plans
        return recorder

    def on_plan(self, record: PlanRecord) -> None:
        """Keep the update's record (its knots copied; its traces only when `wants_traces`)."""
        traces = (
            None
            if record.traces is None or not self.wants_traces
            else np.array(record.traces, np.float32)
        )
        self.plans.append(dataclasses.replace(record, knots=np.array(record.knots), traces=traces))

    def on_step(self, record: StepRecord) -> None:
        """Keep the step's record (its arrays are copied, so the caller may reuse them). Raises
        JudoError for a step whose metadata lacks a `recorded_metadata` key or holds one that is not
        numbers of the first step's shape."""
        metadata = {"mocap_pos": np.array(record.metadata["mocap_pos"])} if self.nmocap else {}
        for key in self.recorded_metadata:
            metadata[key] = self.recorded_value(record, key)
        state = None if record.state is None else np.array(record.state)
        measured = None if record.measured is None else np.array(record.measured, dtype=float)
        estimate = None if record.estimate is None else np.array(record.estimate, dtype=float)
        age = None if record.measured_age is None else np.array(record.measured_age, dtype=float)
        sensors, action = np.array(record.sensors), np.array(record.action)
        hits = record.limit_hits
        self.steps.append(
            StepRecord(record.time, state, sensors, action, metadata, measured, estimate, age, hits)
        )

    def episode(
        self, seed: int, rewards: np.ndarray, metrics: dict[str, float], success: bool | None
    ) -> EpisodeArrays:
        """The recorded episode as the dataset's arrays, with its (S,) per-step `rewards`, metrics
        and success."""
        steps = self.steps
        states = np.array([step.state for step in steps], dtype=float).reshape(
            len(steps), self.nq + self.nv
        )
        mocap = None
        if self.nmocap:
            mocap = np.array([step.metadata["mocap_pos"] for step in steps], dtype=float).reshape(
                len(steps), -1
            )
        metadata = {
            key: np.array([step.metadata[key] for step in steps], dtype=float)
            for key in self.recorded_metadata
        }
        return EpisodeArrays(
            seed=seed,
            qpos=states[:, : self.nq],
            qvel=states[:, self.nq :],
            sensors=np.array([step.sensors for step in steps], dtype=float).reshape(len(steps), -1),
            mocap_pos=mocap,
            actions=np.array([step.action for step in steps], dtype=float).reshape(
                len(steps), self.nu
            ),
            rewards=np.asarray(rewards, dtype=float).reshape(len(steps)),
            plan=self.plan_arrays(),
            metrics=metrics,
            success=success,
            measured=rows_where_given([step.measured for step in steps]),
            estimate=rows_where_given([step.estimate for step in steps]),
            measured_sensors=self.measured_sensors,
            metadata=metadata,
            measured_age=rows_where_given([step.measured_age for step in steps]),
            # where a [safety] limit acted
            limit_hits=[hit for step in steps for hit in step.limit_hits] or None,
        )

    def recorded_value(self, record: StepRecord, key: str) -> np.ndarray:
        """A float copy of `record.metadata[key]`; JudoError, naming the task and the key, where the
        step has none or one that is not numbers of the shape of the first step's."""
        where = (
            f"{self.task_name} records system metadata {key!r} (Task.recorded_metadata), but its "
            "step at "
        )
        where += f"t = {record.time:g} s"
        if key not in record.metadata:
            raise JudoError(
                f"{where} published none (its metadata holds {sorted(record.metadata)})"
            )
        try:
            value = np.array(record.metadata[key], dtype=float)
        except (TypeError, ValueError):
            raise JudoError(
                f"{where} published {type(record.metadata[key]).__name__}, not numbers"
            ) from None
        first = self.steps[0].metadata[key] if self.steps else value
        if value.shape != first.shape:
            raise JudoError(f"{where} published shape {value.shape}, the first step {first.shape}")
        return value

    def plan_arrays(self) -> dict[str, np.ndarray]:
        """{"times", "takes_effect", "update_ms", "best_reward", "mean_reward"}: (U,); "knots": (U,
        num_nodes, nu); and, where the plans carry traces, "traces": (U, 1 + num_shown, T,
        num_trace_sensors, 3) float32."""
        plans = self.plans
        arrays: dict[str, Any] = {
            key: np.array([getattr(plan, key) for plan in plans], dtype=float)
            for key in ("time", "takes_effect", "update_ms", "best_reward", "mean_reward")
        }
        arrays["times"] = arrays.pop("time")
        arrays["knots"] = np.array([plan.knots for plan in plans], dtype=float).reshape(
            len(plans), self.num_nodes, self.nu
        )
        traces = [plan.traces for plan in plans if plan.traces is not None]
        if plans and len(traces) == len(plans):  # every plan carries traces
            arrays["traces"] = padded_stack(traces)
        return arrays


def metadata_settings(task: Task) -> tuple[tuple[str, ...], str]:
    """(`task.recorded_metadata`, its class name): what an EpisodeRecorder of `task` keeps of each
    step's metadata."""
    return tuple(task.recorded_metadata), type(task).__name__


def rows_where_given(rows: list[np.ndarray | None]) -> np.ndarray | None:
    """(S, m): the given rows stacked, NaN where a row is None (e.g. before an estimator was
    switched on); None when no row is given (a full-state episode)."""
    given = [row for row in rows if row is not None]
    if not given:
        return None
    out = np.full((len(rows), len(given[0])), np.nan)
    for i, row in enumerate(rows):
        if row is not None:
            out[i] = row
    return out


def padded_stack(arrays: list[np.ndarray]) -> np.ndarray:
    """(U, *largest shape) float32: the arrays stacked, each padded with NaN to the largest along
    every axis (a live recording's traces change shape with edits of the horizon or
    max_num_traces)."""
    shape = np.max([array.shape for array in arrays], axis=0)
    out = np.full((len(arrays), *shape), np.nan, dtype=np.float32)
    for i, array in enumerate(arrays):
        out[(i, *(slice(0, n) for n in array.shape))] = array
    return out


class PolicyServedRecorder(EpisodeRecorder):
    """An EpisodeRecorder for policy-served collection (collect --policy FILE.onnx --optimizer O):
    the policy drives the plant while its expert, the MPC, plans from every state the policy is
    served from.

    `plan/*` holds the MPC's plans (the labels: its knots, its best and mean rewards, its update
    time), as in a file collected with the MPC driving; `actions` the policy's served actions; and
    besides them `mpc_actions` (S, nu), the MPC's newest plan at the time each step was served, and
    `policy/knots` (U, H, nu) and `policy/inference_ms` (U,), the policy's chunks and inference
    times.
    """

    def __init__(
        self, controller: PolicyController, timestep: float, *sizes: Any, **settings: Any
    ) -> None:
        super().__init__(*sizes, **settings)
        # the plant's: a step served before any plan was served at its time less it
        self.timestep = timestep
        assert controller.expert is not None, (
            "policy-served collection needs the MPC as the policy's expert"
        )
        self.controller, self.expert = controller, controller.expert
        self.mpc_actions: list[np.ndarray] = []
        self.policy_knots: list[np.ndarray] = []
        self.inference_ms: list[float] = []
        self._served_at: float | None = None  # time of the reading the next step is served from

    @classmethod
    def for_policy(
        cls, controller: PolicyController, plant_task: Task, traces: bool = False
    ) -> "PolicyServedRecorder":
        """A recorder for `controller` (with its expert) and the plant model (`sim_model`) of
        `plant_task`."""
        model = plant_task.sim_model
        assert controller.expert is not None, (
            "a policy-served recording needs the expert MPC that labels"
        )
        num_nodes = controller.expert.optimizer.num_nodes
        sizes = (model.nq, model.nv, model.nmocap, num_nodes, model.nu)
        measured = tuple(plant_task.measured_sensors)
        recorded, name = metadata_settings(plant_task)
        return cls(
            controller,
            float(model.opt.timestep),
            *sizes,
            measured_sensors=measured,
            traces=traces,
            recorded_metadata=recorded,
            task_name=name,
        )

    def on_plan(self, record: PlanRecord) -> None:
        """Keep the policy's chunk and inference time, and record the MPC's plan from the same
        reading."""
        inference = self.controller.inference_ms[-1]
        self.policy_knots.append(np.array(record.knots))
        self.inference_ms.append(inference)
        if self._served_at is None:
            self._served_at = record.time
        knots = self.expert.nominal_knots
        knots = np.full((self.num_nodes, self.nu), np.nan) if knots is None else knots
        super().on_plan(
            dataclasses.replace(record, knots=knots, update_ms=record.update_ms - inference)
        )

    def on_step(self, record: StepRecord) -> None:
        """Keep the step, and the MPC's action at the time it was served (the label of the served
        action)."""
        super().on_step(record)
        served_at = record.time - self.timestep if self._served_at is None else self._served_at
        self.mpc_actions.append(np.array(self.expert.action(served_at, record.state), dtype=float))
        self._served_at = record.time

    def episode(
        self, seed: int, rewards: np.ndarray, metrics: dict[str, float], success: bool | None
    ) -> EpisodeArrays:
        """The episode's arrays with `mpc_actions` (S, nu) and the policy's plans {"knots",
        "inference_ms"}."""
        arrays = super().episode(seed, rewards, metrics, success)
        horizon = self.controller.policy.horizon
        arrays.mpc_actions = np.array(self.mpc_actions, dtype=float).reshape(
            len(self.mpc_actions), self.nu
        )
        arrays.policy_plan = {
            "knots": np.array(self.policy_knots, dtype=float).reshape(
                len(self.policy_knots), horizon, self.nu
            ),
            "inference_ms": np.array(self.inference_ms, dtype=float),
        }
        return arrays
