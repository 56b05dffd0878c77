"""StateBuffer: versioned, frozen snapshots, never torn under concurrent writers and readers."""

import threading
from dataclasses import dataclass

import numpy as np
import pytest

from judo.runtime.exchange import StateBuffer


@dataclass
class Reading:
    label: int
    values: np.ndarray


def test_latest_is_none_until_published_and_versions_grow_across_topics():
    buffer = StateBuffer()
    assert buffer.latest("system") is None
    first = buffer.publish("system", 1)
    second = buffer.publish("plan", 2)
    third = buffer.publish("system", 3)
    assert (first.version, second.version, third.version) == (1, 2, 3)
    assert buffer.latest("system").value == 3
    assert buffer.latest("plan").value == 2
    buffer.clear("plan")
    assert buffer.latest("plan") is None


def test_published_value_is_a_private_read_only_copy():
    buffer = StateBuffer()
    values = np.zeros(3)
    buffer.publish("system", Reading(0, values))
    values[:] = 7.0  # the writer reuses its array at once
    stored = buffer.latest("system").value
    assert np.array_equal(stored.values, np.zeros(3))
    with pytest.raises(ValueError, match="read-only"):
        stored.values[0] = 1.0


def test_concurrent_writers_and_readers_never_see_a_torn_snapshot():
    """Each writer fills one reused array with a single value and labels the reading with it; a
    reader that saw a half-written array, or values not matching their label, would be a torn
    read."""
    buffer = StateBuffer()
    stop = threading.Event()
    torn: list[str] = []
    reads = [0]

    def write(writer: int) -> None:
        values = np.empty(2000)
        for i in range(1500):
            label = writer * 1_000_000 + i
            values[:1000] = label  # two separate writes, so a copy taken between them would be torn
            values[1000:] = label
            buffer.publish("system", Reading(label, values))

    def read() -> None:
        last_version = 0
        while not stop.is_set():
            snapshot = buffer.latest("system")
            if snapshot is None:
                continue
            reading = snapshot.value
            if not (reading.values == reading.label).all():
                torn.append(f"label {reading.label} with values {np.unique(reading.values)[:4]}")
            if snapshot.version < last_version:
                torn.append(f"version went back from {last_version} to {snapshot.version}")
            last_version = snapshot.version
            reads[0] += 1

    writers = [threading.Thread(target=write, args=(w,)) for w in range(3)]
    readers = [threading.Thread(target=read) for _ in range(3)]
    for thread in readers + writers:
        thread.start()
    for thread in writers:
        thread.join()
    stop.set()
    for thread in readers:
        thread.join()
    assert torn == []
    assert reads[0] > 100
    assert buffer.latest("system").version == 3 * 1500
