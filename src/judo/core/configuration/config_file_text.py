"""A TOML config file's text, read safely (`read_config_text`: checked with stat before it is
opened, and as it is read), and ConfigFileError, raised for a config file that cannot be read or
applied (judo.core.configuration.config_file applies it)."""

import os
import stat
from pathlib import Path

from judo.core.errors import JudoError

MAX_CONFIG_BYTES = 1_000_000
"""Largest config file read: a config is a few hundred lines; anything bigger is not one."""


class ConfigFileError(JudoError):
    """A config file that cannot be read or applied; the message names the file and the offending
    key."""


def read_config_text(path: str | Path) -> str:
    """The text of the config file at `path`, checked before it is opened and as it is read.

    Raises ConfigFileError, in one line, for an empty path, a missing or unreadable file, a
    directory, a FIFO, device or socket (checked with stat first, so reading never blocks or runs
    out of memory), a file over MAX_CONFIG_BYTES, a binary file (a NUL byte) and text that is not
    UTF-8.
    """
    if str(path).strip() in ("", "."):
        raise ConfigFileError("--config needs the path of a TOML file, got an empty path (or '.')")
    path = Path(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise ConfigFileError(f"config file not found: {path}") from None
    except OSError as err:
        raise ConfigFileError(f"cannot read config file {path}: {err.strerror or err}") from None
    if stat.S_ISDIR(info.st_mode):
        raise ConfigFileError(f"config file {path} is a directory; give the path of a TOML file")
    if not stat.S_ISREG(info.st_mode):
        raise ConfigFileError(
            f"config file {path} is not a regular file (a FIFO, device or socket); give a TOML file"
        )
    if info.st_size > MAX_CONFIG_BYTES:
        raise ConfigFileError(
            f"config file {path} is {info.st_size} bytes; a config file is at most "
            f"{MAX_CONFIG_BYTES} bytes"
        )
    try:
        with open(path, "rb") as file:
            data = file.read(MAX_CONFIG_BYTES + 1)  # the file may have grown since stat
    except OSError as err:
        raise ConfigFileError(f"cannot read config file {path}: {err.strerror or err}") from None
    if len(data) > MAX_CONFIG_BYTES:
        raise ConfigFileError(
            f"config file {path} is over {MAX_CONFIG_BYTES} bytes; a config file is at most that"
        )
    if b"\0" in data:
        raise ConfigFileError(
            f"config file {path} is binary (it holds NUL bytes); give a TOML text file"
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data[: err.start].count(b"\n") + 1
        raise ConfigFileError(
            f"config file {path} is not UTF-8 text (byte {err.start}, line {line}); save it "
            "as UTF-8"
        ) from None
