"""The command-line boundary every command shares (the app, `evaluate`, `benchmark`, `tune`): bounds
on sizes, output paths checked before any work starts, and a user's exception told in one line.
"""

import os
import tempfile
import traceback
from pathlib import Path

from judo.core.configuration.config import require, shown
from judo.core.errors import ConfigError

MAX_WORKERS = 1024
"""Most rollout threads (or trials at once) a command may ask for: beyond it MuJoCo runs out of
memory."""
MAX_SAMPLES = 100_000
"""Most timed (or warm-up) updates `benchmark` may ask for per pair: its arrays are allocated up
front."""
MAX_DURATION = 1e9
"""Longest run in seconds of sim time (about 30 years): its step count always fits an integer."""
MAX_EPISODE = 86_400.0
"""Longest `evaluate` or `tune` episode in seconds of sim time (a day)."""
MAX_SEED = 2**31 - 1
"""Largest episode seed (--first-seed plus the count, less one): a seed fits an int32 wherever it is
read back (a dataset's demo_<seed>, a JSON record, a learner's own PRNG)."""
JUDO_DIR = str(Path(__file__).resolve().parents[1])


def check_count(option: str, value: int | None, high: int, low: int = 1) -> None:
    """Raise ConfigError unless `value` is None (not given) or low <= `value` <= high, naming
    `option`."""
    require(
        value is None or low <= value <= high,
        f"{option} must be an integer from {low} to {high}, got {shown(value)}",
    )


def check_seed_range(first: int, count: int, count_option: str) -> None:
    """Raise ConfigError unless the seeds `first` .. `first` + `count` - 1 all lie in 0 .. MAX_SEED;
    the message names --first-seed, its valid range for this `count`, and `count_option` (--seeds or
    --episodes)."""
    high = MAX_SEED - max(count, 1) + 1
    require(
        0 <= first <= high,
        f"--first-seed must be an integer from 0 to {high} (the last seed, --first-seed + "
        f"{count_option} - 1, is at "
        f"most {MAX_SEED}), got {shown(first)}",
    )


def check_output_file(option: str, path: Path | None, beside: tuple[str, ...] = ()) -> None:
    """Raise ConfigError now, before any work, unless `path` (when given) can be written as a file:
    every name on its path (and the names in `beside`, of the files or folders the command writes
    next to it) short enough for the file system, not a folder, inside a folder that exists or can
    be made, writable by this user."""
    if path is None:
        return
    require(str(path).strip() not in ("", "."), f"{option} needs a file path, got an empty path")
    # before any stat: a too-long name makes it raise
    for name in (*path.absolute().parts[1:], *beside):
        check_name_length(option, name)
    require(not path.is_dir(), f"{option} {shown(str(path))} is a folder; give a file path")
    _check_writable_folder(option, path.parent)


def check_name_length(option: str, name: str) -> None:
    """ConfigError unless `name` fits the longest file name the file system allows (its limit where
    this process runs; 255 bytes where it does not say)."""
    try:
        limit = os.pathconf(".", "PC_NAME_MAX")
    # no pathconf (Windows) or no answer for this file system
    except (OSError, ValueError, AttributeError):
        limit = 255
    size = len(os.fsencode(name))
    require(
        size <= limit,
        f"{option}: the name {shown(name)} is {size} bytes long; the file system allows at "
        f"most {limit}; "
        "give a shorter name",
    )


def check_output_folder(option: str, path: Path | None) -> None:
    """Raise ConfigError now, before any work, unless `path` (when given) is, or can be made, a
    writable folder."""
    if path is None:
        return
    require(
        not (path.exists() and not path.is_dir()),
        f"{option} {shown(str(path))} is a file; give a folder",
    )
    _check_writable_folder(option, path)


def _check_writable_folder(option: str, folder: Path) -> None:
    """ConfigError unless `folder`, or the nearest folder above it that exists, is a writable
    folder."""
    existing = folder.absolute()
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise ConfigError(
            f"{option}: {shown(str(existing))} is a file, so {shown(str(folder))} cannot be made"
        )
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ConfigError(f"{option}: cannot write in {shown(str(existing))} (permission denied)")
    # os.access allows root everything, also where nothing can be made (/proc, a read-only mount): a
    # real file
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as err:
        why = err.strerror or type(err).__name__
        raise ConfigError(
            f"{option}: cannot write in {shown(str(existing))} (no file can be made there: {why})"
        ) from None


def user_error_line(err: BaseException) -> str:
    """`err` in one line: its type and message, and where it was raised, by the innermost frame
    outside judo's own code (the user's class and method, file and line), e.g. "RuntimeError: cannot
    build the task (raised in InitFails.__init__, my_task.py:15)"."""
    message = " ".join(str(err).split())
    text = f"{type(err).__name__}: {message[:200]}" if message else type(err).__name__
    frames = traceback.extract_tb(err.__traceback__)
    outside = [
        f
        for f in frames
        if not f.filename.startswith(JUDO_DIR) and "site-packages" not in f.filename
    ]
    frame = (outside or frames or [None])[-1]
    if frame is None:
        return text
    return f"{text} (raised in {_qualname(err, frame)}, {frame.filename}:{frame.lineno})"


def _qualname(err: BaseException, frame: traceback.FrameSummary) -> str:
    """The qualified name (Class.method) of `frame`'s function, found in `err`'s traceback."""
    tb = err.__traceback__
    while tb is not None:
        code = tb.tb_frame.f_code
        if code.co_filename == frame.filename and tb.tb_lineno == frame.lineno:
            return getattr(code, "co_qualname", code.co_name)
        tb = tb.tb_next
    return frame.name
