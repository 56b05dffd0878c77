"""`EpisodeRecorder`: a Recorder that gathers one episode's steps and plans into the dataset's arrays."""

import dataclasses
from typing import Any

import numpy as np

from judo.collection.dataset import EpisodeArrays
from judo.runtime.records import PlanRecord, StepRecord


class EpisodeRecorder:
    """Accumulates the StepRecords and PlanRecords of one closed-loop episode (the `Recorder` protocol).

    Args:
        nq, nv: sizes of the plant's qpos and qvel, to split each step's (nq + nv,) state.
        nmocap: the plant's mocap bodies; with any, each step's metadata must hold "mocap_pos" (nmocap, 3).
        num_nodes, nu: shape of a plan's knots, for the (0, num_nodes, nu) array of an episode with no plan.
    """

    def __init__(self, nq: int, nv: int, nmocap: int, num_nodes: int, nu: int) -> None:
        self.nq, self.nv, self.nmocap, self.num_nodes, self.nu = nq, nv, nmocap, num_nodes, nu
        self.steps: list[StepRecord] = []
        self.plans: list[PlanRecord] = []

    def on_plan(self, record: PlanRecord) -> None:
        """Keep the update's record (its knots copied)."""
        self.plans.append(dataclasses.replace(record, knots=np.array(record.knots)))

    def on_step(self, record: StepRecord) -> None:
        """Keep the step's record (its arrays are copied, so the caller may reuse them)."""
        metadata = {"mocap_pos": np.array(record.metadata["mocap_pos"])} if self.nmocap else {}
        state = None if record.state is None else np.array(record.state)
        self.steps.append(StepRecord(record.time, state, np.array(record.sensors), np.array(record.action), metadata))

    def episode(self, seed: int, rewards: np.ndarray, metrics: dict[str, float], success: bool | None) -> EpisodeArrays:
        """The recorded episode as the dataset's arrays, with its (S,) per-step `rewards`, metrics and success."""
        steps = self.steps
        states = np.array([step.state for step in steps], dtype=float).reshape(len(steps), self.nq + self.nv)
        mocap = None
        if self.nmocap:
            mocap = np.array([step.metadata["mocap_pos"] for step in steps], dtype=float).reshape(len(steps), -1)
        return EpisodeArrays(
            seed=seed,
            qpos=states[:, : self.nq],
            qvel=states[:, self.nq :],
            sensors=np.array([step.sensors for step in steps], dtype=float).reshape(len(steps), -1),
            mocap_pos=mocap,
            actions=np.array([step.action for step in steps], dtype=float).reshape(len(steps), self.nu),
            rewards=np.asarray(rewards, dtype=float).reshape(len(steps)),
            plan=self.plan_arrays(),
            metrics=metrics,
            success=success,
        )

    def plan_arrays(self) -> dict[str, np.ndarray]:
        """{"times", "takes_effect", "update_ms", "best_reward", "mean_reward"}: (U,); "knots": (U, num_nodes, nu)."""
        plans = self.plans
        arrays: dict[str, Any] = {
            key: np.array([getattr(plan, key) for plan in plans], dtype=float)
            for key in ("time", "takes_effect", "update_ms", "best_reward", "mean_reward")
        }
        arrays["times"] = arrays.pop("time")
        arrays["knots"] = np.array([plan.knots for plan in plans], dtype=float).reshape(
            len(plans), self.num_nodes, self.nu
        )
        return arrays
