"""Ray for evaluate, tune and collect: start a local Ray, or join a running cluster, and run
functions as Ray tasks.

Ray runs offline: no usage statistics and no dashboard. `address` None starts a local Ray with
`workers` CPUs, listening on 127.0.0.1 only (as the GUI does); "auto" joins the cluster started on
this machine with `ray start --head`; "HOST:PORT" or "ray://HOST:PORT" joins a remote one. Every
episode (of a trial, a collect run, an evaluate --workers run) is a task needing one CPU, so a
cluster runs as many episodes at once as it has CPUs. `run_windowed` is the one loop that runs a
command's episodes here, a window of them in flight under a progress bar (evaluate
--workers/--address in evaluation/evaluate.py, collect in collection/run.py); tune's study
(tuning/study.py) asks Optuna for trials between the same `submit` and `wait_any`. This module knows
no command.
"""

import logging
import os
import socket
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from judo.core.commandline.interrupts import sigint_as_flag
from judo.core.errors import JudoError, import_extra

CONNECT_TIMEOUT_S = 5.0
"""How long to try reaching a cluster's address before giving up."""
WAIT_SLICE_S = 0.5
"""How long one `ray.wait` may block before a pending Ctrl-C is checked."""
LOCAL_RAY_HOST = "127.0.0.1"
"""The address a local Ray (no --address) listens on: this machine only, as the GUI by default."""
LOCAL_START_ATTEMPTS = 2
"""How many times a local Ray is started before giving up (a loaded machine can miss Ray's fixed
start-up wait)."""


T = TypeVar("T")


class RayClusterError(JudoError):
    """A Ray cluster that cannot be started or reached; the message says how to start one."""


RAY_TOKEN_LOGGER = "ray._private.authentication.authentication_token_setup"
"""The logger of Ray's notice that a new local Ray turned token authentication on (as it does by
default)."""


def _not_the_token_notice(record: logging.LogRecord) -> bool:
    return not record.getMessage().startswith(
        "Token authentication is enabled for this Ray cluster"
    )


def import_ray(feature: str = "python -m judo tune", extra: str = "tune") -> Any:
    """The ray module, or MissingExtraError naming `extra` as what `feature` needs. Ray's notice
    that a local Ray uses token authentication (its default; nothing for the user to do) is left
    out; its other warnings stay."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    notices = logging.getLogger(RAY_TOKEN_LOGGER)
    if _not_the_token_notice not in notices.filters:
        notices.addFilter(_not_the_token_notice)
    return import_extra("ray", feature, extra)


def check_reachable(address: str) -> None:
    """RayClusterError unless a TCP connection to `address` ("[ray://]HOST:PORT") opens within the
    timeout."""
    host_port = address.removeprefix("ray://")
    host, _, port = host_port.rpartition(":")
    if not host or not port.isdigit():
        raise RayClusterError(
            f"--address {address!r}: expected auto, HOST:PORT or ray://HOST:PORT (e.g. "
            "ray://10.0.0.5:10001)"
        )
    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as err:
        raise RayClusterError(
            f"cannot reach a Ray cluster at {address!r}: {err}. Start one with `ray start "
            "--head` on the head "
            "machine (and `ray start --address=HEAD:6379` on the others), then pass "
            "--address auto on the head "
            "or --address ray://HEAD:10001 from elsewhere"
        ) from None


def start_ray(address: str | None, workers: int) -> bool:
    """Start (address None) or join Ray, unless this process is already connected to one (a
    notebook's, a test's), which is then used as it is. Returns whether it connected, i.e. whether
    `stop_ray` should follow."""
    ray = import_ray()
    if address not in (None, "auto"):
        check_reachable(address)
    if ray.is_initialized():
        return False
    options: dict[str, Any] = {
        "include_dashboard": False,
        "log_to_driver": False,
        "configure_logging": False,
    }
    if address is None:
        options.update(
            num_cpus=workers, runtime_env=local_runtime_env(), _node_ip_address=LOCAL_RAY_HOST
        )
    # A local Ray on a loaded machine can miss Ray's own fixed 30 s wait for its raylet (a bare
    # Exception, "timed out during startup"): the start is tried again from scratch before giving
    # up.
    attempts = LOCAL_START_ATTEMPTS if address is None else 1
    for attempt in range(1, attempts + 1):
        try:
            with _on_loopback(address is None):
                ray.init(address=address, **options)
            return True
        except Exception as err:  # Ray raises a bare Exception for a node that timed out starting
            if not isinstance(
                err, (ConnectionError, RuntimeError, ValueError)
            ) and "timed out" not in str(err):
                raise
            ray.shutdown()
            if attempt == attempts:
                raise RayClusterError(
                    "could not "
                    f"{'start a local Ray' if address is None else f'join the Ray cluster at {address!r}'}"  # noqa: E501
                    f"{f' in {attempts} tries' if attempts > 1 else ''}: "
                    f"{str(err).splitlines()[0]}. "
                    "For a cluster, start it with `ray start --head` first"
                ) from None
    return True


@contextmanager
def _on_loopback(local: bool) -> Iterator[None]:
    """While a local Ray starts (`local`), let it keep 127.0.0.1 as its node address, so that its
    GCS, raylet and workers listen there only. Ray turns a node address of 127.0.0.1 into the
    machine's network address unless its cluster support is off (`ray_constants.ENABLE_RAY_CLUSTER`,
    as Ray has it on macOS and Windows); it is off for the start alone and restored after, so a
    later `--address` joins a cluster as before."""
    # ray's private constants module (no stubs), or None when not starting a local Ray
    constants: Any = None
    if local:
        # no public switch: see tests/tuning/test_local_ray.py
        from ray._private import ray_constants

        constants = ray_constants
    saved = getattr(constants, "ENABLE_RAY_CLUSTER", None)
    if saved is not None:
        constants.ENABLE_RAY_CLUSTER = False
    try:
        yield
    finally:
        if saved is not None:
            constants.ENABLE_RAY_CLUSTER = saved


def local_runtime_env() -> dict[str, Any]:
    """Ray's runtime_env for a local Ray: its workers import judo from where this process does (a
    source checkout included), ahead of whatever PYTHONPATH already holds."""
    source = str(Path(__file__).resolve().parent.parent)  # the folder that holds the judo package
    inherited = os.environ.get("PYTHONPATH", "")
    return {"env_vars": {"PYTHONPATH": os.pathsep.join(filter(None, [source, inherited]))}}


def cluster_cpus() -> int:
    """CPUs of the Ray this process is connected to: how many trials can run at once."""
    return max(1, int(import_ray().cluster_resources().get("CPU", 1)))


def submit(function: Any, *args: Any) -> Any:
    """Start `function(*args)` as a Ray task needing one CPU, never retried; returns its
    ObjectRef."""
    ray = import_ray()
    return ray.remote(num_cpus=1, max_retries=0)(function).remote(*args)


def wait_any(refs: list[Any]) -> tuple[list[Any], list[Any]]:
    """(finished, still running) refs, waiting until at least one is finished.

    Waits in slices of WAIT_SLICE_S with Ctrl-C turned into a flag, and raises KeyboardInterrupt
    here, between the slices: a SIGINT that lands inside Ray's own blocking wait once went
    unanswered (collect's Ctrl-C test in CI ran on for a minute without printing a line), and this
    way a stop takes effect within WAIT_SLICE_S.
    """
    ray = import_ray()
    while True:
        with sigint_as_flag() as interrupted:
            done, running = ray.wait(refs, num_returns=1, timeout=WAIT_SLICE_S)
        if interrupted:
            raise KeyboardInterrupt
        if done:
            return done, running


def get(ref: Any, lost: Callable[[str], T]) -> T:
    """The value of a finished ref, or `lost(reason)` when the Ray task itself died (a worker crash,
    a cancel)."""
    ray = import_ray()
    try:
        return ray.get(ref)
    except Exception as err:  # RayTaskError, WorkerCrashedError, TaskCancelledError, ...
        return lost(f"Ray task failed: {type(err).__name__}: {err}")


class EpisodeCounts:
    """Finished and failed episodes and their rate, the description of `run_windowed`'s progress
    bar; a command that counts more says so in `detail`."""

    def __init__(self) -> None:
        self.done = self.failed = 0
        self.started = time.perf_counter()

    def detail(self) -> str:
        """What the command counts besides done and failed (", kept 3"), shown between them and the
        rate."""
        return ""

    def line(self) -> str:
        """done, failed, the detail and episodes per minute."""
        minutes = (time.perf_counter() - self.started) / 60.0
        rate = self.done / minutes if minutes > 0 else 0.0
        return f"done {self.done}, failed {self.failed}{self.detail()}, {rate:.1f} episodes/min"


def run_windowed(
    function: Callable[..., Any],
    tasks: Sequence[tuple[Any, ...]],
    take: Callable[[tuple[Any, ...], Any], None],
    lost: Callable[[tuple[Any, ...], str], Any],
    counts: EpisodeCounts,
    *,
    label: str,
    episodes: int,
    address: str | None,
    local_cpus: int,
    window: int | None,
    console: Console,
    per_task: int = 1,
    progress: Callable[..., Progress] = Progress,
) -> None:
    """Run `function(*args)` for each `args` of `tasks` as a Ray task on a local Ray with
    `local_cpus` CPUs (address None) or the cluster at `address`, at most `window` episodes in
    flight (twice the Ray's CPUs when None; a task holds `per_task` episodes), and hand each
    finished one to `take(args, value)` as it finishes; a task that died gives `lost(args, reason)`
    as its value. A transient `progress(*columns, console=console, transient=True)` display
    (cli_shared.progress_display: plain lines where `console` is no terminal) labelled `label` shows
    `counts.done` of `episodes` with `counts.line()`; `take` keeps the counts.

    Ray is stopped after if this call started or joined it. On any exception (Ctrl-C's
    KeyboardInterrupt, or one `take` raised) the tasks still running are cancelled and it is raised
    again.
    """
    running: dict[Any, tuple[Any, ...]] = {}
    pending = iter(tasks)
    columns = (
        TextColumn(label),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.description}"),
    )
    connected = False
    try:
        connected = start_ray(address, local_cpus)
        window = window or 2 * cluster_cpus()
        with progress(*columns, TimeElapsedColumn(), console=console, transient=True) as display:
            bar = display.add_task(counts.line(), total=episodes)
            while True:
                while (
                    len(running) * per_task < window and (args := next(pending, None)) is not None
                ):
                    running[submit(function, *args)] = args
                if not running:
                    break
                ready, _ = wait_any(list(running))
                for ref in ready:
                    args = running.pop(ref)
                    take(args, get(ref, lambda reason, args=args: lost(args, reason)))
                display.update(bar, completed=counts.done, description=counts.line())
    except BaseException:
        cancel(list(running))
        raise
    finally:
        if connected:
            stop_ray()


def cancel(refs: list[Any]) -> None:
    """Cancel running tasks (on Ctrl-C or an error) without killing their workers: each gets a
    KeyboardInterrupt and replies as cancelled; an episode returns to Python every plant step, so it
    lands within one step. `force=True` raced the replies of tasks that were just finishing and
    aborted Ray's core worker ("Tried to complete task that was not pending", task_manager.cc) in a
    CI run of collect's Ctrl-C test."""
    ray = import_ray()
    for ref in refs:
        ray.cancel(ref, force=False)


def stop_ray() -> None:
    """Shut this process's Ray connection (and a local Ray it started) down."""
    ray = import_ray()
    if ray.is_initialized():
        ray.shutdown()
