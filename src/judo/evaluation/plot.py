"""Plot of one episode against time: positions, velocities, controls and reward, as PNG or HTML.

PNG needs matplotlib (the optional `plot` extra, imported only when a PNG is asked for:
`optional_pyplot`). HTML needs nothing: it is one self-contained file with inline SVG, viewable
offline in any browser.
"""

import html
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from judo.cli_shared import optional_pyplot
from judo.core.errors import ConfigError, JudoError
from judo.evaluation.episode import EpisodeResult

PLOT_SUFFIXES = (".png", ".html")
COLORS = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)
MAX_LEGEND = 10


@dataclass
class Panel:
    """One subplot: `values` (S, k) against time, with one label per column."""

    title: str
    labels: list[str]
    values: np.ndarray


def state_labels(model: mujoco.MjModel) -> tuple[list[str], list[str]]:
    """Names of the nq qpos entries and the nv qvel entries, from joint names (`joint[i]` for
    multi-entry joints)."""
    qpos_sizes = {mujoco.mjtJoint.mjJNT_FREE: 7, mujoco.mjtJoint.mjJNT_BALL: 4}
    qvel_sizes = {mujoco.mjtJoint.mjJNT_FREE: 6, mujoco.mjtJoint.mjJNT_BALL: 3}
    qpos, qvel = [""] * model.nq, [""] * model.nv
    for joint in range(model.njnt):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, joint) or f"joint{joint}"
        kind = mujoco.mjtJoint(model.jnt_type[joint])
        for labels, start, size in (
            (qpos, model.jnt_qposadr[joint], qpos_sizes.get(kind, 1)),
            (qvel, model.jnt_dofadr[joint], qvel_sizes.get(kind, 1)),
        ):
            for i in range(size):
                labels[start + i] = name if size == 1 else f"{name}[{i}]"
    return qpos, qvel


def episode_panels(result: EpisodeResult, model: mujoco.MjModel) -> list[Panel]:
    """The four panels of an episode of a plant on `model`."""
    qpos_labels, qvel_labels = state_labels(model)
    actuators = [
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) or f"u{i}"
        for i in range(model.nu)
    ]
    states = result.log.states
    return [
        Panel("positions (qpos)", qpos_labels, states[:, : model.nq]),
        Panel("velocities (qvel)", qvel_labels, states[:, model.nq :]),
        Panel("controls", actuators, result.log.controls),
        Panel("reward per step", ["reward"], result.rewards[:, None]),
    ]


def check_plot_path(path: Path) -> None:
    """Raise a JudoError now, before any episode runs, if `path` cannot be plotted to."""
    if path.suffix.lower() not in PLOT_SUFFIXES:
        raise ConfigError(
            f"--plot needs a file ending in {' or '.join(PLOT_SUFFIXES)}, got {str(path)!r}"
        )
    if path.suffix.lower() == ".png":
        _import_pyplot()


def write_episode_plot(
    result: EpisodeResult, model: mujoco.MjModel, path: Path, title: str
) -> None:
    """Write the episode's plot to `path`: PNG via matplotlib, or self-contained HTML."""
    check_plot_path(path)
    panels = episode_panels(result, model)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".png":
        _write_png(result.log.times, panels, path, title)
    else:
        path.write_text(_html_page(result.log.times, panels, title))


def _import_pyplot():  # matplotlib is optional, so it is not imported for annotations
    plt = optional_pyplot()
    if plt is None:
        raise JudoError(
            "a PNG plot needs matplotlib, which is not installed: pip install -e '.[plot]', "
            "or give a .html path"
        )
    return plt


def _write_png(times: np.ndarray, panels: list[Panel], path: Path, title: str) -> None:
    plt = _import_pyplot()
    figure, axes = plt.subplots(
        len(panels), 1, sharex=True, figsize=(9, 2.2 * len(panels)), squeeze=False
    )
    for axis, panel in zip(axes[:, 0], panels, strict=True):
        for column, label in enumerate(panel.labels):
            axis.plot(
                times,
                panel.values[:, column],
                label=label if column < MAX_LEGEND else None,
                linewidth=1,
            )
        axis.set_title(panel.title, fontsize=10)
        axis.grid(alpha=0.3)
        if 1 < len(panel.labels):
            axis.legend(fontsize=7, loc="upper right", ncol=min(len(panel.labels), 5))
    axes[-1, 0].set_xlabel("time (s)")
    figure.suptitle(title)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def _html_page(times: np.ndarray, panels: list[Panel], title: str) -> str:
    body = "\n".join(_svg_panel(times, panel) for panel in panels)
    return (
        f"<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        "<style>body{font-family:sans-serif;margin:20px} "
        "svg{display:block;margin-bottom:12px}</style>"
        f"</head><body><h2>{html.escape(title)}</h2>\n{body}\n</body></html>\n"
    )


def _svg_panel(times: np.ndarray, panel: Panel, width: int = 900, height: int = 200) -> str:
    left, right, top, bottom = 60, 10, 24, 24
    low, high = float(np.nanmin(panel.values)), float(np.nanmax(panel.values))
    if high - low < 1e-12:
        low, high = low - 1.0, high + 1.0
    t0, t1 = float(times[0]), float(max(times[-1], times[0] + 1e-9))
    xs = left + (times - t0) / (t1 - t0) * (width - left - right)
    lines, legend = [], []
    for column, label in enumerate(panel.labels):
        color = COLORS[column % len(COLORS)]
        ys = top + (high - panel.values[:, column]) / (high - low) * (height - top - bottom)
        points = " ".join(f"{x:.1f},{y:.1f}" for x, y in zip(xs, ys, strict=True))
        lines.append(f"<polyline fill='none' stroke='{color}' stroke-width='1' points='{points}'/>")
        if column < MAX_LEGEND:
            legend.append(f"<tspan fill='{color}'>{html.escape(label)} </tspan>")
    return (
        f"<svg xmlns='http://www.w3.org/2000/svg' width='{width}' height='{height}'>"
        f"<rect x='{left}' y='{top}' width='{width - left - right}' "
        f"height='{height - top - bottom}' "
        "fill='none' stroke='#ccc'/>"
        f"<text x='{left}' y='16' font-size='13'>{html.escape(panel.title)}: "
        f"{''.join(legend)}</text>"
        f"<text x='{left - 4}' y='{top + 10}' font-size='10' text-anchor='end'>{high:.3g}</text>"
        f"<text x='{left - 4}' y='{height - bottom}' font-size='10' "
        f"text-anchor='end'>{low:.3g}</text>"
        f"<text x='{left}' y='{height - 8}' font-size='10'>{t0:.2f} s</text>"
        f"<text x='{width - right}' y='{height - 8}' font-size='10' "
        f"text-anchor='end'>{t1:.2f} s</text>"
        f"{''.join(lines)}</svg>"
    )
