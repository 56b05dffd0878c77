"""The checks of an App's run settings, made before anything is built: a bad one is a one-line ConfigError."""

import math

from judo.core.config import check_seed
from judo.core.errors import ConfigError

MAX_WORKERS = 1024
"""Most rollout threads an app may ask for."""


def check_app_settings(
    duration: float | None,
    num_workers: int | None,
    seed: int | None,
    system_call_limit: float,
    user_system: bool,
    observe: str,
) -> None:
    """Raise ConfigError, saying what is wrong and what is valid, for a duration, rollout-thread count, seed or
    System-call limit out of range, or rehearsed sensing (`observe` not "state") asked of a `user_system`."""
    if duration is not None and not 0 < duration < math.inf:
        raise ConfigError(
            f"duration must be a positive, finite number of seconds of sim time (or None to run until stopped), "
            f"got {duration}"
        )
    if num_workers is not None and not (isinstance(num_workers, int) and 1 <= num_workers <= MAX_WORKERS):
        raise ConfigError(
            f"num_workers must be an integer from 1 to {MAX_WORKERS} (or None: one per core), got {num_workers!r}"
        )
    check_seed(seed)
    if not 0 < system_call_limit < math.inf:
        raise ConfigError(f"system_call_limit must be a positive, finite number of seconds, got {system_call_limit}")
    if user_system and observe != "state":
        raise ConfigError(
            f"observe={observe!r} rehearses sensing on the app's own simulation; your System chooses what it "
            "measures (return SystemState.sensors, state None), so leave observe at 'state'"
        )
