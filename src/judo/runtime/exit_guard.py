"""Stop every running App before the interpreter finalizes, so a script that ends without `app.stop()`
never segfaults at exit.

A script that starts an App and ends (or raises) without stopping it leaves the app's thread and the
rollout threads running: they are daemon threads, so Python finalizes the interpreter under them while
they are still inside MuJoCo, and the process dies with SIGSEGV (rc 139) in most runs. `atexit` hooks
run after the main thread ends and before finalization, so the one hook here stops each App that
`register` was given and waits for its threads.

The hook is (re-)registered on each `register`, after the GUI server started, so it runs before
viser's own exit hook (atexit runs the last registered first): the app stops its GUI itself.
"""

import atexit
import threading
import weakref
from typing import Protocol


class Stoppable(Protocol):
    """What the hook needs of an App."""

    def stop(self, timeout: float | None = ...) -> None: ...


EXIT_STOP_TIMEOUT = 5.0
"""Seconds the exit hook waits for each running App to stop (its planning cycle in flight to end)."""

_running: "weakref.WeakSet[Stoppable]" = weakref.WeakSet()
_lock = threading.Lock()


def register(app: Stoppable) -> None:
    """Have `app` stopped (`app.stop(EXIT_STOP_TIMEOUT)`) at interpreter exit if it is still running then.

    Call it once the app has started; stopping an app that already stopped does nothing harmful."""
    with _lock:
        _running.add(app)
        atexit.unregister(stop_running_apps)
        atexit.register(stop_running_apps)


def stop_running_apps() -> None:
    """Stop every registered App, each waited for at most EXIT_STOP_TIMEOUT seconds."""
    with _lock:
        apps = list(_running)
        _running.clear()
    for app in apps:
        try:
            app.stop(timeout=EXIT_STOP_TIMEOUT)
        except Exception:  # noqa: BLE001  (at exit, one app failing to stop must not skip the others)
            pass
