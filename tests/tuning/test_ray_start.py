"""A local Ray that misses Ray's own start-up wait on a loaded machine is started again, and one
that never starts is one line naming the tries. Real Ray: the first `ray.init` is made to raise what
Ray raises then."""

import pytest

import judo.ray_cluster as cluster

ray = pytest.importorskip("ray")


def test_a_local_start_that_misses_rays_startup_wait_is_tried_again(monkeypatch):
    """A loaded machine can miss Ray's fixed 30 s wait for its raylet (a bare Exception); the start
    is tried anew."""
    if ray.is_initialized():
        pytest.skip("this process is already connected to a Ray")
    real_init = ray.init
    calls: list[dict] = []

    def init_that_times_out_once(**kwargs):
        calls.append(kwargs)
        if len(calls) == 1:
            raise Exception(
                "The current node timed out during startup. This could happen because ..."
            )
        return real_init(**kwargs)

    monkeypatch.setattr(ray, "init", init_that_times_out_once)
    try:
        assert cluster.start_ray(None, 1) is True
        assert len(calls) == cluster.LOCAL_START_ATTEMPTS == 2
        assert ray.is_initialized() and ray.get(cluster.submit(lambda: 1 + 1)) == 2
    finally:
        cluster.stop_ray()


def test_a_local_start_that_keeps_timing_out_is_one_line_naming_the_tries(monkeypatch):
    if ray.is_initialized():
        pytest.skip("this process is already connected to a Ray")

    def init_that_times_out(**kwargs):
        raise Exception("The current node timed out during startup. This could happen because ...")

    monkeypatch.setattr(ray, "init", init_that_times_out)
    with pytest.raises(
        cluster.RayClusterError,
        match=r"could not start a local Ray "
        r"in 2 tries: The current node",
    ):
        cluster.start_ray(None, 1)
