"""MujocoSystem reports every kind of blow-up, including those MuJoCo resets silently inside
mj_step."""

import numpy as np
import pytest

from judo.loop.system import MujocoSystem, SimulationDiverged


def test_a_huge_velocity_is_reported_even_though_mujoco_resets_it(upright_task):
    # beyond MuJoCo's 1e10 limit: mjWARN_BADQVEL, reset inside mj_step
    upright_task.data.qvel[:] = [1e11, 0.0]
    upright_task.data.time = 2.5
    system = MujocoSystem(upright_task)
    with pytest.raises(SimulationDiverged, match=r"simulation of UprightTask diverged at t=2.5"):
        system.step()
    assert np.isfinite(system.read_state().state).all()
    system.step()  # the warning counters were cleared: the next normal step is fine
    # the clock kept running through the reset
    assert system.read_state().time == pytest.approx(2.52)
