"""The four top-level Unitree messages' CDR, written with `struct`: what cyclonedds' own
(pure-Python) serializer makes of them, bit for bit, several times faster, since the bridge writes a
LowCmd_ and reads a LowState_ 500 times a second.

A @final struct of primitives and fixed arrays, in XCDR1 (the representation cyclonedds writes for
such a type, and a Unitree robot's own), is a 4-byte encapsulation header (00 01 00 00: CDR,
little-endian) then each primitive at its natural alignment counted from the payload's start, with
no padding of a struct's own (where the C layout of `judo.unitree.crc` pads each struct to its
widest member). `install` gives the message classes this `serialize` and `deserialize`; any other
request (XCDR2, another endianness, a buffer) and any bytes that are not little-endian XCDR1 go to
cyclonedds' own.
"""

import struct
from functools import cache
from typing import Any

from judo.unitree.crc import PRIMITIVES, fields_of, kind_of, plan_of, values_of

HEADER = b"\x00\x01\x00\x00"
"""XCDR1, little-endian, no options."""


def _runs(cls: type, out: list[tuple[str, int, int]]) -> None:
    """Append (struct code, size, count) for each primitive or primitive array of `cls`, structs
    expanded."""
    for _, hint in fields_of(cls):
        kind, what, n = kind_of(hint)
        if kind == "struct":
            _runs(what, out)
        elif kind == "array" and isinstance(what, type):
            for _ in range(n):
                _runs(what, out)
        else:
            name = what if kind == "prim" else what.__metadata__[0]
            code, size = PRIMITIVES[name]
            out.append((code, size, n))


@cache
def cdr_format(cls: type) -> str:
    """The `struct` format of `cls`'s XCDR1 payload (little-endian, each primitive aligned from the
    payload's start)."""
    runs: list[tuple[str, int, int]] = []
    _runs(cls, runs)
    codes, offset = ["<"], 0
    for code, size, count in runs:
        pad = -offset % size
        codes.append((f"{pad}x" if pad else "") + f"{count}{code}")
        offset += pad + size * count
    codes.append(f"{-offset % 4}x" if offset % 4 else "")
    return "".join(codes)


def serialize(message: Any, buffer=None, endianness=None, use_version_2=None) -> bytes:
    """`message` as cyclonedds' XCDR1 bytes (its own serializer for anything else asked)."""
    if buffer is not None or endianness is not None or use_version_2:
        return type(message).__idl__.serialize(
            message, buffer=buffer, endianness=endianness, use_version_2=use_version_2
        )
    values: list = []
    values_of(message, values)
    return HEADER + struct.pack(cdr_format(type(message)), *values)


@cache
def _shape(cls: type) -> list[tuple[str, str, Any, int]]:
    """(field name, kind, element class or primitive name, count) of each field of `cls`, in
    order."""
    shape = []
    for (name, kind), (_, hint) in zip(plan_of(cls), fields_of(cls), strict=True):
        _, what, n = kind_of(hint)
        shape.append((name, kind, what.__metadata__[0] if kind == "array" else what, n))
    return shape


def _build(cls: type, values: tuple, at: int) -> tuple[Any, int]:
    """(an instance of `cls` from the flat `values` from index `at`, the index after it)."""
    kwargs: dict[str, Any] = {}
    for name, kind, what, n in _shape(cls):
        if kind == "struct":
            kwargs[name], at = _build(what, values, at)
        elif kind == "structs":
            items = []
            for _ in range(n):
                item, at = _build(what, values, at)
                items.append(item)
            kwargs[name] = items
        elif kind == "array":
            run = values[at : at + n]
            kwargs[name] = bytes(run) if what == "uint8" else list(run)
            at += n
        else:
            kwargs[name], at = values[at], at + 1
    return cls(**kwargs), at


def deserializer(cls: type):
    """A `deserialize` classmethod body for `cls`: little-endian XCDR1 by `cdr_format`, else
    cyclonedds' own."""

    def deserialize(data: bytes, has_header: bool = True, use_version_2=None) -> Any:
        if not has_header or bytes(data[:4]) != HEADER or use_version_2:
            return cls.__idl__.deserialize(data, has_header=has_header, use_version_2=use_version_2)
        message, _ = _build(cls, struct.unpack_from(cdr_format(cls), data, 4), 0)
        return message

    return deserialize


def install(*classes: type) -> None:
    """Give each of `classes` this module's `serialize` and `deserialize`."""
    for cls in classes:
        cls.serialize = serialize
        cls.deserialize = staticmethod(deserializer(cls))
