"""The Unitree remote's stop: L2+B held, read from a LowState_'s wireless_remote bytes, latches
judo's stop."""

import time

import pytest

pytest.importorskip("cyclonedds")

import leg_task
from unitree_links import Streamer, Wire, drive, free_domain, leg_options, leg_state

from judo.safety.stop import StopLatch
from judo.unitree import messages as msg
from judo.unitree.bridge import REMOTE_KEYS, REMOTE_SOURCE, UnitreeSystem, remote_keys


def held(*keys: str) -> list[int]:
    """(40,) wireless_remote bytes with `keys` held, laid out as Unitree's xRockerBtnDataStruct
    (head, keys, sticks)."""
    bits = sum(1 << REMOTE_KEYS.index(key) for key in keys)
    return [0x55, 0x51, *bits.to_bytes(2, "little"), *[0] * 36]


def decoded(remote: list[int], cls=msg.GoLowState):
    message = cls()
    message.wireless_remote = remote
    return cls.deserialize(message.serialize())  # as a reader takes it off the wire


@pytest.mark.parametrize("cls", [msg.GoLowState, msg.HgLowState], ids=["go2", "g1"])
def test_the_keys_are_read_from_a_decoded_lowstate(cls):
    assert remote_keys(decoded(held("L2", "B"), cls).wireless_remote) == {"L2", "B"}
    assert remote_keys(decoded(held("R1", "left"), cls).wireless_remote) == {"R1", "left"}
    assert remote_keys(decoded([0] * 40, cls).wireless_remote) == frozenset()
    # byte 2 bit 5 is L2 and byte 3 bit 1 is B in Unitree's layout
    assert decoded(held("L2", "B"), cls).wireless_remote[2:4] == bytes([0b0010_0000, 0b0000_0010])


def test_l2_and_b_on_the_robots_lowstate_latch_the_stop_and_b_alone_does_not():
    domain = free_domain()
    wire = Wire(domain)
    streamer = Streamer(wire)
    latch = StopLatch(None)
    latch.listen()
    system = UnitreeSystem(leg_task.UnitreeLeg(), leg_options(domain))
    try:
        drive(system, leg_task.STAND, 0.2)
        streamer.make = lambda tick: with_remote(leg_state(leg_task.STAND, tick), held("B"))
        drive(system, leg_task.STAND, 0.3)
        assert not latch.latched  # one key of the pair is no stop
        streamer.make = lambda tick: with_remote(leg_state(leg_task.STAND, tick), held("L2", "B"))
        deadline = time.monotonic() + 20
        while not latch.latched and time.monotonic() < deadline:
            drive(system, leg_task.STAND, 0.05)
        assert latch.latched and latch.latest is not None and latch.latest.source == REMOTE_SOURCE
        streamer.make = lambda tick: leg_state(leg_task.STAND, tick)  # released: the latch stays
        drive(system, leg_task.STAND, 0.2)
        assert latch.latched and len(latch.events) == 1
    finally:
        streamer.stop()
        system.close()
        wire.close()
        latch.close()


def with_remote(state, remote: list[int]):
    """`state` (a LowState_ with its CRC) with the remote's bytes `remote`, its CRC made again."""
    from judo.unitree import crc

    state.wireless_remote = remote
    return crc.with_crc(state)
