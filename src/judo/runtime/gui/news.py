"""What the app's callbacks hand the GUI loop: the newest value of each kind of news, kept until a
frame takes it.

The app calls the GUI's subscriptions (`AppPort.on_state`, `on_plan`, ...) on the thread that made
the news: the plant's, the planner's, a command's. Each callback only `put`s into a `Latest`, which
takes a lock for one assignment, so a control thread never waits on drawing; the GUI loop (about 30
Hz) `take`s what came since its last frame and draws it.
"""

import threading
from typing import Generic, TypeVar

T = TypeVar("T")


class Latest(Generic[T]):
    """The newest value put and not yet taken (None: nothing new)."""

    def __init__(self, value: T | None = None) -> None:
        self._lock = threading.Lock()
        self._value = value

    def put(self, value: T) -> None:
        """Keep `value`, replacing one not yet taken (any thread)."""
        with self._lock:
            self._value = value

    def take(self) -> T | None:
        """The newest value since the last take, or None; it is taken."""
        with self._lock:
            value, self._value = self._value, None
        return value

    def restore(self, value: T) -> None:
        """Put back `value` taken but not yet used, unless a newer one came meanwhile."""
        with self._lock:
            if self._value is None:
                self._value = value

    def waiting(self) -> bool:
        """True while a value waits to be taken."""
        return self._value is not None
