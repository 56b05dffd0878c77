"""The metric a tune optimises: one of evaluate's metrics of the task, and whether it is better
higher or lower."""

from dataclasses import dataclass
from typing import Literal

from judo.core.configuration.registry import lookup_task
from judo.core.errors import JudoError

Direction = Literal["maximize", "minimize"]
MEAN_REWARD = "mean_reward"
"""The metric evaluate reports for every task (the mean per-step reward); the one used without a
metrics hook."""


class UnknownMetricError(JudoError):
    """A --metric that the task's episodes do not report; the message lists the ones they do."""


@dataclass(frozen=True)
class Objective:
    """What a trial's score is: `metric` averaged over seeds, to `direction`."""

    metric: str
    direction: Direction

    def better(self, a: float, b: float) -> bool:
        """Whether score `a` beats score `b`."""
        return a > b if self.direction == "maximize" else a < b


def metric_direction(task_name: str, metric: str) -> Direction:
    """ "minimize" for a metric the task lists in `lower_is_better`, else "maximize" (mean_reward
    included)."""
    task_cls = lookup_task(task_name)[0]
    return "minimize" if metric in task_cls.lower_is_better else "maximize"


def make_objective(
    task_name: str, metric: str | None, reported: list[str], direction: Direction | None = None
) -> Objective:
    """The objective for `metric` (None: mean_reward), checked against the metrics an episode
    `reported`.

    Raises UnknownMetricError listing the task's metrics when `metric` is not among them.
    """
    metric = metric or MEAN_REWARD
    if metric not in reported:
        raise UnknownMetricError(
            f"task {task_name!r} reports no metric {metric!r}; its metrics are: "
            f"{', '.join(reported)}"
        )
    return Objective(metric, direction or metric_direction(task_name, metric))
