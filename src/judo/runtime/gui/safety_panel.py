"""The GUI's read-only list of the safety limits in force (`judo.safety`): one line per limit, from
the session's serve filter, or a line saying that none is set. The limits are set before the run (a
[safety.TASK] table, `--safety.*`); the page only shows them."""

import viser

from judo.safety.limits import Limits


def limit_lines(limits: Limits | None) -> list[str]:
    """One line per limit in force ("position slider: -0.3 to 0.3", "rate push: units/s <= 20",
    ...); [] for None."""
    if limits is None:
        return []
    pairs = zip(limits.position, limits.position_low, limits.position_high, strict=True)
    shown = [f"position {name}: {low:g} to {high:g}" for name, low, high in pairs]
    for kind, unit in (("velocity", "|qvel| <="), ("effort", "|force| <="), ("rate", "units/s <=")):
        caps = zip(getattr(limits, kind), getattr(limits, f"{kind}_max"), strict=True)
        shown += [f"{kind} {name}: {unit} {cap:g}" for name, cap in caps]
    if limits.workspace_frame:
        low, high = limits.workspace_low.tolist(), limits.workspace_high.tolist()
        shown.append(f"workspace {limits.workspace_frame}: {low} to {high} m")
    return shown + [
        f"contact {name}: <= {limits.max_contact_force:g} N" for name in limits.contact_geoms
    ]


class SafetyPanel:
    """A folder "Safety limits" at `order` listing `limits` (None: no [safety] limits), read-only,
    until `remove()`."""

    def __init__(self, gui: viser.GuiApi, limits: Limits | None, order: float) -> None:
        lines = limit_lines(limits)
        self.text = (
            "\n".join(f"- `{line}`" for line in lines)
            if lines
            else "No limits set ([safety.TASK], --safety.*)."
        )
        self.folder = gui.add_folder("Safety limits", order=order, expand_by_default=False)
        with self.folder:
            self.markdown = gui.add_markdown(self.text)

    def remove(self) -> None:
        """Take the folder off the page."""
        self.folder.remove()
