"""Live uPlot charts of the app's figures: nominal reward, plan time, achieved control rate,
real-time factor, and, while an estimator runs in simulation, the estimation error."""

from collections import deque

import mujoco
import numpy as np
import viser
import viser.uplot

from judo.runtime.snapshots import LiveFigures

HISTORY = 120
"""Points kept per chart: the last 30 s at 4 points a second, so the y-range follows the recent
window and an early spike (a first plan, a fall) leaves the chart within half a minute."""

CHARTS = (
    ("nominal_reward", "nominal reward", "reward (-)", "#d62728"),
    ("plan_time_ms", "plan time (ms)", "plan time (ms)", "#1f77b4"),
    ("control_rate", "control rate (Hz)", "rate (Hz)", "#2ca02c"),
    ("real_time_factor", "real-time factor", "sim s / wall s", "#9467bd"),
)
"""(LiveFigures attribute, chart title, y-axis label with units, line colour) of each chart."""


ESTIMATION_TITLE = "estimation error"
ESTIMATION_SERIES = (("position (mm, mrad)", "#ff7f0e"), ("velocity (mm/s, mrad/s)", "#17becf"))
"""(series label, line colour) of the estimation-error chart: the norms of the position and velocity
errors, drawn in thousandths (mm and mrad), whose ticks read 1.5 and 2 where metres' read 0.001, 0
and 0."""
ESTIMATION_SCALE = 1e3
"""Units drawn per SI unit on the estimation-error chart (m -> mm, rad -> mrad)."""


def estimation_error(
    model: mujoco.MjModel, true_state: np.ndarray, estimate: np.ndarray
) -> tuple[float, float]:
    """(position, velocity) error norms of the (nq + nv,) `estimate` against `true_state`: the
    position error in tangent space (`mj_differentiatePos`, so a quaternion's error is an angle in
    rad), both in mixed units (m and rad; m/s and rad/s)."""
    nq, nv = model.nq, model.nv
    difference = np.zeros(nv)
    mujoco.mj_differentiatePos(
        model, difference, 1.0, np.asarray(true_state[:nq], float), np.asarray(estimate[:nq], float)
    )
    velocity = np.asarray(estimate[nq : nq + nv], float) - np.asarray(
        true_state[nq : nq + nv], float
    )
    return float(np.linalg.norm(difference)), float(np.linalg.norm(velocity))


class Plots:
    """One chart per figure, in a folder titled "Plots"; `add(t, figures)` appends a point to each.

    `show_estimation(True)` adds the estimation-error chart (two lines: position and velocity error
    norms), `add_estimation(t, position, velocity)` appends to it.
    """

    def __init__(self, gui: viser.GuiApi, order: float) -> None:
        self.gui = gui
        self.estimation: viser.GuiUplotHandle | None = None
        self._estimation_history: deque[tuple[float, float, float]] = deque(maxlen=HISTORY)
        self.folder = gui.add_folder("Plots", order=order)
        self._history: dict[str, deque[tuple[float, float]]] = {
            key: deque(maxlen=HISTORY) for key, *_ in CHARTS
        }
        self.charts: dict[str, viser.GuiUplotHandle] = {}
        with self.folder:
            for key, title, y_label, colour in CHARTS:
                self.charts[key] = gui.add_uplot(
                    (np.zeros(0), np.zeros(0)),
                    (
                        viser.uplot.Series(label="wall time (s)"),
                        viser.uplot.Series(label=title, stroke=colour, width=2),
                    ),
                    title=title,
                    scales={
                        "x": viser.uplot.Scale(time=False, auto=True),
                        "y": viser.uplot.Scale(auto=True),
                    },
                    axes=(
                        viser.uplot.Axis(label="wall time (s)", labelSize=18),
                        # room for values like -2,000
                        viser.uplot.Axis(label=y_label, size=64, labelSize=18),
                    ),
                    legend=viser.uplot.Legend(show=False),
                    aspect=2.0,
                    padding=(12, 24, 0, 0),  # room above the top tick label
                )

    def clear(self) -> None:
        """Forget every point (after a reset or a switch: the old run's figures no longer apply)."""
        for key, chart in self.charts.items():
            self._history[key].clear()
            chart.data = (np.zeros(0), np.zeros(0))
        self._estimation_history.clear()
        if self.estimation is not None:
            self.estimation.data = (np.zeros(0), np.zeros(0), np.zeros(0))

    def show_estimation(self, shown: bool) -> None:
        """Add the estimation-error chart (at the top of the folder), or take it away."""
        if shown and self.estimation is None:
            with self.folder:
                self.estimation = self.gui.add_uplot(
                    (np.zeros(0), np.zeros(0), np.zeros(0)),
                    (
                        viser.uplot.Series(label="wall time (s)"),
                        *(
                            viser.uplot.Series(label=label, stroke=colour, width=2)
                            for label, colour in ESTIMATION_SERIES
                        ),
                    ),
                    title=ESTIMATION_TITLE,
                    scales={
                        "x": viser.uplot.Scale(time=False, auto=True),
                        "y": viser.uplot.Scale(auto=True),
                    },
                    axes=(
                        viser.uplot.Axis(label="wall time (s)", labelSize=18),
                        viser.uplot.Axis(label="error (mm, mrad)", size=64, labelSize=18),
                    ),
                    legend=viser.uplot.Legend(show=True),
                    aspect=2.0,
                    padding=(12, 24, 0, 0),
                    order=-1,
                )
        elif not shown and self.estimation is not None:
            self.estimation.remove()
            self.estimation = None
            self._estimation_history.clear()

    def add_estimation(self, t: float, position: float, velocity: float) -> None:
        """Append the estimation error norms at wall time `t` and redraw (nothing while the chart is
        hidden)."""
        if self.estimation is None or not (np.isfinite(position) and np.isfinite(velocity)):
            return
        self._estimation_history.append(
            (t, ESTIMATION_SCALE * position, ESTIMATION_SCALE * velocity)
        )
        points = np.array(self._estimation_history)
        self.estimation.data = (points[:, 0], points[:, 1], points[:, 2])

    def add(self, t: float, figures: LiveFigures) -> None:
        """Append the finite figures at wall time `t` (seconds since the app started) and redraw."""
        for key, chart in self.charts.items():
            value = getattr(figures, key)
            if not np.isfinite(value):
                continue
            history = self._history[key]
            history.append((t, value))
            points = np.array(history)
            chart.data = (points[:, 0], points[:, 1])
