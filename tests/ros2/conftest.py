"""The ROS 2 tests' shared plant process."""

import subprocess
from collections.abc import Iterator

import pytest
from ros2_links import free_domain, start_plant, stop_process


@pytest.fixture(scope="module")
def plant() -> Iterator[tuple[subprocess.Popen, int]]:
    """One cartpole plant process for the tests of a module that echoes every command it reads:
    (process, domain)."""
    domain = free_domain()
    proc = start_plant(domain, "--echo")
    yield proc, domain
    stop_process(proc)
