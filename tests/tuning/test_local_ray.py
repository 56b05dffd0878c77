"""The local Ray that collect, evaluate --workers and tune start (`start_ray` without --address)
listens on 127.0.0.1 only, as the GUI does, runs tasks there, and leaves Ray's cluster support as it
found it."""

import os

import pytest

import judo.ray_cluster as cluster

ray = pytest.importorskip("ray")
psutil = pytest.importorskip("psutil")  # a dependency of ray


def listening_addresses() -> set[str]:
    """The IP addresses that this process and its children (Ray's GCS, raylet and workers) listen
    on."""
    processes = [psutil.Process(), *psutil.Process().children(recursive=True)]
    found = set()
    for process in processes:
        try:
            connections = process.net_connections(kind="inet")
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
        found |= {c.laddr.ip for c in connections if c.status == psutil.CONN_LISTEN}
    return found


def test_a_local_ray_listens_on_loopback_only_and_runs_tasks(local_ray):
    from ray._private import ray_constants

    # restored once the local Ray started (a cluster is joined as before)
    assert ray_constants.ENABLE_RAY_CLUSTER
    assert ray.get_runtime_context().gcs_address.startswith("127.0.0.1:")
    assert {node["NodeManagerAddress"] for node in ray.nodes()} == {"127.0.0.1"}
    # a task ran, in a worker of that Ray
    assert ray.get(cluster.submit(lambda: os.getpid())) != os.getpid()
    addresses = listening_addresses()
    assert addresses, "no listening socket found for Ray's processes"
    assert addresses <= {"127.0.0.1", "::ffff:127.0.0.1"}, addresses


def test_the_windowed_loop_hands_over_each_task_and_a_dead_one_as_lost(local_ray):
    import io
    import json

    from rich.console import Console

    taken: list[tuple[tuple, object]] = []
    counts = cluster.EpisodeCounts()

    def take(args: tuple, value: object) -> None:
        taken.append((args, value))
        counts.done += 1
        counts.failed += isinstance(value, str)

    cluster.run_windowed(
        json.loads,
        [("[1]",), ("not json",), ("[3]",)],
        take,
        lambda args, reason: reason,
        counts,
        label="test",
        episodes=3,
        address=None,
        local_cpus=2,
        window=1,  # one task at a time: they finish in the order given
        console=Console(file=io.StringIO()),
    )
    assert [args for args, _ in taken] == [("[1]",), ("not json",), ("[3]",)]
    assert taken[0][1] == [1] and taken[2][1] == [3]
    assert str(taken[1][1]).startswith("Ray task failed: ") and "JSONDecodeError" in str(
        taken[1][1]
    )
    assert (counts.done, counts.failed) == (3, 1) and counts.line().startswith("done 3, failed 1, ")
    assert ray.is_initialized()  # the Ray this process was already connected to is left running
