"""Unitree's CRC of a LowCmd_ / LowState_: what a Unitree robot checks before it runs a command.

The message is laid out as the C struct of its IDL (each field at its natural alignment, each struct
padded to its widest member, little-endian), read as 32-bit little-endian words, and every word but
the last (the `crc` field itself) is fed most significant bit first through the CRC-32 polynomial
0x04C11DB7 from 0xFFFFFFFF, with no reflection and no final XOR: CRC-32/MPEG-2 over each word's
big-endian bytes (the STM32's hardware CRC).

The layout is read off the message class's own IDL annotations (`struct_format`), so there is one
description of each type (judo.unitree.messages). The CRC itself runs in C: CRC-32/MPEG-2 is zlib's
CRC-32 with every input byte and the result bit-reversed and the final XOR undone.
"""

import struct
import typing
import zlib
from functools import cache
from typing import Any

import numpy as np

PRIMITIVES = {
    "uint8": ("B", 1),
    "int8": ("b", 1),
    "uint16": ("H", 2),
    "int16": ("h", 2),
    "uint32": ("I", 4),
    "int32": ("i", 4),
    "float32": ("f", 4),
}
"""IDL primitive -> (struct code, size and alignment in bytes)."""
_REVERSED_BYTE = np.array([int(f"{b:08b}"[::-1], 2) for b in range(256)], np.uint8)


@cache
def fields_of(cls: type) -> list[tuple[str, Any]]:
    return list(typing.get_type_hints(cls, include_extras=True).items())


def kind_of(hint: Any) -> tuple[str, Any, int]:
    """("prim", code name, 1), ("array", element hint, n) or ("struct", class, 1) of one field's
    type hint."""
    if isinstance(hint, type):
        return "struct", hint, 1
    (meta,) = hint.__metadata__
    if isinstance(meta, str):
        return "prim", meta, 1
    return "array", meta.subtype, int(meta.length)


@cache
def _layout(cls: type) -> tuple[list[str], int]:
    """(struct codes with padding, in order; the struct's alignment) of IDL struct `cls` as C lays
    it out, offsets counted from the struct's start."""
    codes: list[str] = []
    offset, align = 0, 1

    def place(hint: Any, count: int) -> None:
        nonlocal offset, align
        kind, what, _ = kind_of(hint) if not isinstance(hint, str) else ("prim", hint, 1)
        if kind == "struct":
            inner, inner_align = _layout(what)
            size = struct.calcsize("<" + "".join(inner))
            pad = -offset % inner_align
            codes.append(f"{pad}x" if pad else "")
            codes.extend(inner * count)
            offset += pad + size * count
            align = max(align, inner_align)
            return
        code, size = PRIMITIVES[what]
        pad = -offset % size
        codes.append((f"{pad}x" if pad else "") + f"{count}{code}")
        offset += pad + size * count
        align = max(align, size)

    for _, hint in fields_of(cls):
        kind, what, n = kind_of(hint)
        if kind == "array":
            place(what if isinstance(what, type) else what.__metadata__[0], n)
        else:
            place(hint, 1)
    tail = -offset % align
    if tail:
        codes.append(f"{tail}x")
    return [c for c in codes if c], align


@cache
def struct_format(cls: type) -> str:
    """The `struct` format of IDL struct `cls` laid out as its C struct (little-endian, with
    padding)."""
    return "<" + "".join(_layout(cls)[0])


def packed_size(cls: type) -> int:
    """Bytes of `cls` as its C struct."""
    return struct.calcsize(struct_format(cls))


@cache
def plan_of(cls: type) -> list[tuple[str, str]]:
    """(field name, "struct" | "structs" | "array" | "prim") of each field of `cls`, in order."""
    plan = []
    for name, hint in fields_of(cls):
        kind, what, _ = kind_of(hint)
        plan.append((name, "structs" if kind == "array" and isinstance(what, type) else kind))
    return plan


def values_of(message: Any, out: list) -> None:
    for name, kind in plan_of(type(message)):
        value = getattr(message, name)
        if kind == "struct":
            values_of(value, out)
        elif kind == "structs":
            for element in value:
                values_of(element, out)
        elif kind == "array":
            out.extend(value)
        else:
            out.append(value)


def pack(message: Any) -> bytes:
    """`message` (an IDL struct of judo.unitree.messages) as the bytes of its C struct."""
    values: list = []
    values_of(message, values)
    return struct.pack(struct_format(type(message)), *values)


def crc32_mpeg2(data: bytes) -> int:
    """CRC-32/MPEG-2 of `data`: polynomial 0x04C11DB7, initial 0xFFFFFFFF, bits fed most significant
    first, no reflection, no final XOR (its catalogued check value, of b"123456789", is
    0x0376E6E7)."""
    reflected = zlib.crc32(_REVERSED_BYTE[np.frombuffer(data, np.uint8)].tobytes()) ^ 0xFFFFFFFF
    return int(f"{reflected:032b}"[::-1], 2)


def crc32_words(words: np.ndarray) -> int:
    """Unitree's CRC-32 of (n,) uint32 `words`, each fed most significant bit first: CRC-32/MPEG-2
    of their big-endian bytes."""
    return crc32_mpeg2(np.asarray(words, dtype=">u4").tobytes())


def crc_of(message: Any) -> int:
    """The CRC a Unitree robot expects in `message.crc`: over every 32-bit word of its C struct but
    the last."""
    data = pack(message)
    return crc32_words(np.frombuffer(data, "<u4")[:-1])


def with_crc(message: Any) -> Any:
    """`message`, its `crc` field set to its CRC (returned for chaining)."""
    message.crc = crc_of(message)
    return message


def crc_ok(message: Any) -> bool:
    """Whether `message.crc` is its CRC, as a robot checks it."""
    return int(message.crc) == crc_of(message)
