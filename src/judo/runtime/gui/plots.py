"""Live uPlot charts of the app's figures: nominal reward, plan time, achieved control rate, real-time factor."""

from collections import deque

import numpy as np
import viser
import viser.uplot

from judo.runtime.commands import LiveFigures

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


class Plots:
    """One chart per figure, in a folder titled "Plots"; `add(t, figures)` appends a point to each."""

    def __init__(self, gui: viser.GuiApi, order: float) -> None:
        self.folder = gui.add_folder("Plots", order=order)
        self._history: dict[str, deque[tuple[float, float]]] = {key: deque(maxlen=HISTORY) for key, *_ in CHARTS}
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
                    scales={"x": viser.uplot.Scale(time=False, auto=True), "y": viser.uplot.Scale(auto=True)},
                    axes=(
                        viser.uplot.Axis(label="wall time (s)", labelSize=18),
                        viser.uplot.Axis(label=y_label, size=64, labelSize=18),  # room for values like -2,000
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
