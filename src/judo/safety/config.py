"""`SafetyConfig`, the owner's limits as given: the `[safety.TASK]` section of a config file and the
`--safety.*` flags, with the checks that need no model (entry syntax, a minimum above its maximum,
negative caps). judo.safety.limits resolves it against a task's planning model.

Every entry names a joint, an actuator, a site, a body or a geom of the planning model; "*" in an
entry's name stands for every joint (velocity) or actuator (effort, rate). A config with no entry is
off: nothing is checked, planned or served differently (`SafetyConfig.active`).
"""

import math
from dataclasses import dataclass

import numpy as np

from judo.core.configuration.config import Config, require
from judo.core.errors import ConfigError


@dataclass
class SafetyConfig(Config):
    """Limits the robot's owner sets; off (no entry) by default. Entries are "NAME=VALUE"
    strings."""

    joint_ranges: bool = False
    """Hold every limited hinge and slide joint inside its MJCF range, shrunk by range_margin at
    each end."""
    range_margin: float = 0.0
    """How far inside each MJCF range joint_ranges holds a joint (rad or m, at least 0)."""
    position: tuple[str, ...] = ()
    """Position limits, "JOINT=LOW:HIGH" (rad or m) of hinge and slide joints; they replace
    joint_ranges' for that joint."""
    velocity: tuple[str, ...] = ()
    """Speed caps, "JOINT=MAX" (rad/s or m/s, |qvel| <= MAX); "*=MAX" for every hinge and slide
    joint."""
    effort: tuple[str, ...] = ()
    """Effort caps, "ACTUATOR=MAX": |actuator force| <= MAX, the force a position actuator's PD
    implies included; "*=MAX" for every actuator."""
    rate: tuple[str, ...] = ()
    """Rate limits, "ACTUATOR=MAX" (command units per second); "*=MAX" for every actuator."""
    workspace_frame: str = ""
    """The frame held inside the workspace box: "base" (the free-joint body), or a site or body that
    a framepos sensor of the model reports; "" for no box."""
    workspace_low: tuple[float, ...] = ()
    """(3,) lower corner of the workspace box in world coordinates (m)."""
    workspace_high: tuple[float, ...] = ()
    """(3,) upper corner of the workspace box in world coordinates (m)."""
    contact_geoms: tuple[str, ...] = ()
    """Geoms whose total contact force is capped by max_contact_force (checked at serve time)."""
    max_contact_force: float = 0.0
    """Cap on the total normal contact force on each of contact_geoms (N); above 0 when
    contact_geoms are given."""

    def validate(self) -> None:
        """The checks that need no model: entry syntax, a minimum above its maximum, negative
        caps."""
        super().validate()
        where = "SafetyConfig"
        for name in ("position", "velocity", "effort", "rate", "contact_geoms"):
            value = getattr(self, name)
            if isinstance(value, str) or not all(isinstance(entry, str) for entry in value):
                raise ConfigError(f"{where}.{name} expects a list of strings, got {value!r}")
            setattr(self, name, tuple(value))
        require(
            math.isfinite(self.range_margin) and self.range_margin >= 0,
            f"{where}.range_margin must be at least 0, got {self.range_margin}",
        )
        position_entries(self.position)
        for name in ("velocity", "effort", "rate"):
            cap_entries(name, getattr(self, name))
        box = [self.workspace_low, self.workspace_high]
        if self.workspace_frame:
            for corner, label in zip(box, ("workspace_low", "workspace_high"), strict=True):
                ok = len(corner) == 3 and all(
                    isinstance(v, (int, float)) and math.isfinite(v) for v in corner
                )
                require(
                    ok,
                    f"{where}.{label} expects 3 finite numbers (x, y, z) with "
                    f"workspace_frame, got {list(corner)}",
                )
            low, high = np.asarray(box[0], float), np.asarray(box[1], float)
            bad = np.flatnonzero(low > high)
            require(
                not len(bad),
                f"{where}: workspace_low {low.tolist()} is above workspace_high "
                f"{high.tolist()} in {'xyz'[bad[0]] if len(bad) else ''}",
            )
        else:
            require(
                not any(box),
                f'{where}: workspace_low/high need a workspace_frame ("base", a site or a body)',
            )
        require(
            math.isfinite(self.max_contact_force) and self.max_contact_force >= 0,
            f"{where}.max_contact_force must be a cap of at least 0 N, got "
            f"{self.max_contact_force}",
        )
        require(
            bool(self.contact_geoms) == (self.max_contact_force > 0),
            f"{where}: contact_geoms {list(self.contact_geoms)} and max_contact_force "
            f"{self.max_contact_force:g} go "
            "together: name the geoms and a cap above 0, or neither",
        )

    @property
    def active(self) -> bool:
        """Whether any limit is set (an inactive config changes nothing anywhere)."""
        return bool(
            self.joint_ranges
            or self.position
            or self.velocity
            or self.effort
            or self.rate
            or self.workspace_frame
            or self.contact_geoms
        )


def _split(name: str, entry: str, what: str) -> tuple[str, str]:
    key, sep, value = entry.partition("=")
    require(
        bool(sep and key.strip() and value.strip()),
        f"SafetyConfig.{name} entry {entry!r} is not {what}",
    )
    return key.strip(), value.strip()


def position_entries(entries: tuple[str, ...]) -> dict[str, tuple[float, float]]:
    """{joint: (low, high)} of "JOINT=LOW:HIGH" entries; ConfigError for a bad entry or a minimum
    above its maximum."""
    limits: dict[str, tuple[float, float]] = {}
    for entry in entries:
        joint, value = _split("position", entry, '"JOINT=LOW:HIGH"')
        parts = value.split(":")
        try:
            low, high = (float(part) for part in parts) if len(parts) == 2 else (math.nan, math.nan)
        except ValueError:
            low = high = math.nan
        require(
            math.isfinite(low) and math.isfinite(high),
            f'SafetyConfig.position entry {entry!r} is not "JOINT=LOW:HIGH" with finite numbers',
        )
        require(
            low <= high,
            f"SafetyConfig.position {joint}: the minimum {low:g} is above the maximum {high:g}",
        )
        require(joint not in limits, f"SafetyConfig.position names {joint!r} twice")
        limits[joint] = (low, high)
    return limits


def cap_entries(name: str, entries: tuple[str, ...]) -> dict[str, float]:
    """{name: cap} of "NAME=MAX" entries; ConfigError for a bad entry, a cap below 0 or a name given
    twice."""
    caps: dict[str, float] = {}
    for entry in entries:
        key, value = _split(name, entry, '"NAME=MAX"')
        try:
            cap = float(value)
        except ValueError:
            cap = math.nan
        require(
            math.isfinite(cap),
            f'SafetyConfig.{name} entry {entry!r} is not "NAME=MAX" with a finite number',
        )
        require(cap >= 0, f"SafetyConfig.{name} {key}: the cap must be at least 0, got {cap:g}")
        require(key not in caps, f"SafetyConfig.{name} names {key!r} twice")
        caps[key] = cap
    return caps
