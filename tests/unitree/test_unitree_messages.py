"""Unitree's message types as judo writes them: type names, field order and sizes as Unitree's IDL
has them, the C-struct layout the CRC covers, and the CRC itself against a bit-at-a-time reference
of the documented algorithm."""

import dataclasses
import struct

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

from judo.unitree import crc
from judo.unitree import messages as msg

FIELDS = {
    msg.GoLowCmd: "head level_flag frame_reserve sn version "
    "bandwidth motor_cmd bms_cmd wireless_remote "
    "led fan gpio "
    "reserve crc",
    msg.GoLowState: "head level_flag frame_reserve sn version "
    "bandwidth imu_state motor_state bms_state "
    "foot_force "
    "foot_force_est tick wireless_remote bit_flag adc_reel temperature_ntc1 temperature_ntc2 "
    "power_v power_a "
    "fan_frequency reserve crc",
    msg.GoMotorCmd: "mode q dq tau kp kd reserve",
    msg.GoMotorState: "mode q dq ddq tau_est q_raw dq_raw ddq_raw temperature lost reserve",
    msg.GoIMUState: "quaternion gyroscope accelerometer rpy temperature",
    msg.GoBmsCmd: "off reserve",
    msg.GoBmsState: "version_high version_low status soc current cycle bq_ntc mcu_ntc cell_vol",
    msg.HgLowCmd: "mode_pr mode_machine motor_cmd reserve crc",
    msg.HgLowState: "version mode_pr mode_machine tick imu_state "
    "motor_state wireless_remote reserve crc",
    msg.HgMotorCmd: "mode q dq tau kp kd reserve",
    msg.HgMotorState: "mode q dq ddq tau_est temperature vol sensor motorstate reserve",
    msg.HgIMUState: "quaternion gyroscope accelerometer rpy temperature",
}
"""Each type's fields in the order of Unitree's IDL (unitree_sdk2's unitree_go and unitree_hg)."""
C_SIZES = {msg.GoLowCmd: 812, msg.GoLowState: 1180, msg.HgLowCmd: 1004, msg.HgLowState: 2092}
"""Bytes of each message as its C struct, which Unitree's CRC covers."""


@pytest.mark.parametrize("cls", list(FIELDS), ids=lambda c: c.__name__)
def test_field_order_and_type_names(cls):
    assert tuple(f.name for f in dataclasses.fields(cls)) == tuple(FIELDS[cls].split())
    package = "unitree_go" if cls.__name__.startswith("Go") else "unitree_hg"
    suffix = {
        "LowCmd": "LowCmd_",
        "LowState": "LowState_",
        "MotorCmd": "MotorCmd_",
        "MotorState": "MotorState_",
    }
    name = suffix.get(cls.__name__[2:], cls.__name__[2:] + "_")
    assert cls.__idl_typename__ == f"{package}::msg::dds_::{name}"


def test_array_sizes():
    go, hg = msg.GoLowState(), msg.HgLowState()
    assert len(go.motor_state) == 20 and len(msg.GoLowCmd().motor_cmd) == 20
    assert len(hg.motor_state) == 35 and len(msg.HgLowCmd().motor_cmd) == 35
    assert (len(go.foot_force), len(go.wireless_remote), len(go.bms_state.cell_vol)) == (4, 40, 15)
    assert (
        len(msg.GoLowCmd().led),
        len(msg.GoMotorCmd().reserve),
        len(msg.HgMotorState().reserve),
    ) == (12, 3, 4)


@pytest.mark.parametrize("cls", list(C_SIZES), ids=lambda c: c.__name__)
def test_c_layout_sizes_and_round_trip(cls):
    assert crc.packed_size(cls) == C_SIZES[cls]
    message = cls()
    assert len(crc.pack(message)) == C_SIZES[cls]
    # cyclonedds' CDR of the type round-trips
    assert cls.deserialize(message.serialize()) == message


def test_c_layout_offsets():
    """The padding a C compiler puts in: MotorCmd_ starts 4-byte aligned after `bandwidth`, `crc` is
    the last word."""
    cmd = msg.GoLowCmd()
    cmd.bandwidth, cmd.motor_cmd[1].mode, cmd.motor_cmd[1].q, cmd.crc = 0xABCD, 7, 1.5, 0x01020304
    data = crc.pack(cmd)
    assert struct.unpack_from("<H", data, 20)[0] == 0xABCD
    # each MotorCmd_ is 36 bytes
    assert data[24 + 36] == 7 and struct.unpack_from("<f", data, 24 + 36 + 4)[0] == 1.5
    assert struct.unpack_from("<I", data, 808)[0] == 0x01020304
    hg = msg.HgLowCmd()
    hg.motor_cmd[0].mode = 9
    assert crc.pack(hg)[4] == 9  # after mode_pr, mode_machine and 2 bytes of padding


def reference_crc(words: list[int]) -> int:
    """Unitree's CRC-32 as documented, one bit at a time: from 0xFFFFFFFF, each 32-bit word most
    significant bit first; shift, and XOR the polynomial 0x04C11DB7 when the bit shifted out differs
    from the data bit."""
    value = 0xFFFFFFFF
    for word in words:
        for bit in range(31, -1, -1):
            feedback = (value >> 31) ^ ((word >> bit) & 1)
            value = (value << 1) & 0xFFFFFFFF
            if feedback:
                value ^= 0x04C11DB7
    return value


def test_crc_of_known_bytes():
    assert crc.crc32_mpeg2(b"123456789") == 0x0376E6E7  # CRC-32/MPEG-2's catalogued check value
    # words fed big-end first
    assert reference_crc([0x31323334, 0x35363738]) == crc.crc32_mpeg2(b"12345678")
    words = np.random.default_rng(0).integers(0, 2**32, 64, dtype=np.uint64).astype(np.uint32)
    assert crc.crc32_words(words) == reference_crc(words.tolist())
    assert crc.crc32_words(np.zeros(0, np.uint32)) == 0xFFFFFFFF


@pytest.mark.parametrize("cls", list(C_SIZES), ids=lambda c: c.__name__)
def test_messages_judo_writes_verify(cls):
    message = cls()
    parts = message.motor_cmd if hasattr(message, "motor_cmd") else message.motor_state
    parts[2].q, parts[5].dq = 0.67, -1.25
    crc.with_crc(message)
    words = np.frombuffer(crc.pack(message), "<u4")
    assert message.crc == reference_crc(words[:-1].tolist()) == words[-1]
    assert crc.crc_ok(message) and crc.crc_ok(cls.deserialize(message.serialize()))
    parts[2].q = 0.6700001  # one changed value, the old CRC
    assert not crc.crc_ok(message)


def random_message(cls, rng):
    """An instance of `cls` with every field random in its type's range (floats exact in
    float32)."""
    ranges = {
        "uint8": (0, 255),
        "int8": (-128, 127),
        "uint16": (0, 65535),
        "int16": (-32768, 32767),
    }
    ranges |= {"uint32": (0, 2**32 - 1), "int32": (-(2**31), 2**31 - 1)}

    def value(name):
        if name == "float32":
            return float(np.float32(rng.normal()))
        return int(rng.integers(*ranges[name], endpoint=True))

    kwargs = {}
    for name, hint in crc.fields_of(cls):
        kind, what, n = crc.kind_of(hint)
        if kind == "struct":
            kwargs[name] = random_message(what, rng)
        elif kind == "array" and isinstance(what, type):
            kwargs[name] = [random_message(what, rng) for _ in range(n)]
        elif kind == "array":
            prim = what.__metadata__[0]
            kwargs[name] = (
                bytes(value(prim) for _ in range(n))
                if prim == "uint8"
                else [value(prim) for _ in range(n)]
            )
        else:
            kwargs[name] = value(what)
    return cls(**kwargs)


@pytest.mark.parametrize("cls", list(C_SIZES), ids=lambda c: c.__name__)
def test_the_fast_cdr_is_cyclonedds_own_bit_for_bit(cls):
    rng = np.random.default_rng(1)
    for _ in range(5):
        message = random_message(cls, rng)
        # cyclonedds' own serializer (XCDR1, its default here)
        reference = cls.__idl__.serialize(message)
        assert message.serialize() == reference
        assert cls.deserialize(reference) == cls.__idl__.deserialize(reference) == message
        # asked for XCDR2: cyclonedds' own, both ways
        version_2 = message.serialize(use_version_2=True)
        assert version_2[:2] == b"\x00\x07" and cls.deserialize(version_2) == message
