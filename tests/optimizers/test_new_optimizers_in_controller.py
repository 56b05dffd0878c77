"""dial, cmaes and icem inside a Controller: determinism, size edits from the GUI, and balancing a
cart-pole."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.configuration.config import with_updates
from judo.loop.system import MujocoSystem

NEW_OPTIMIZERS = ["dial", "cmaes", "icem"]
NEAR_UPRIGHT = np.array([0.1, 0.2, 0.0, 0.0])  # cart x, pole angle (0 = up), velocities


def plan_a_few_cycles(ctrl: judo.Controller, cycles: int, start: float = 0.0) -> float:
    time = start
    for _ in range(cycles):
        ctrl.update_action(NEAR_UPRIGHT, time)
        time += 0.05
    return time


@pytest.mark.parametrize("name", NEW_OPTIMIZERS)
def test_same_seed_same_plans(name):
    plans = []
    for _ in range(2):
        ctrl = judo.make_controller("cartpole", name, seed=7)
        plan_a_few_cycles(ctrl, 3)
        plans.append(ctrl.nominal_knots.copy())
        ctrl.close()
    np.testing.assert_array_equal(plans[0], plans[1])


@pytest.mark.parametrize("name", NEW_OPTIMIZERS)
def test_state_survives_num_nodes_and_num_rollouts_edits(name):
    ctrl = judo.make_controller("cartpole", name, seed=0)
    opt = ctrl.optimizer
    time = plan_a_few_cycles(ctrl, 3)
    generation = getattr(opt, "generation", None)
    opt.config = with_updates(opt.config, {"num_nodes": 7})
    time = plan_a_few_cycles(ctrl, 2, time)
    assert ctrl.nominal_knots.shape == (7, 1) and len(ctrl.rewards) == opt.config.num_rollouts
    opt.config = with_updates(opt.config, {"num_rollouts": 12, "num_nodes": 5})
    plan_a_few_cycles(ctrl, 2, time)
    assert ctrl.nominal_knots.shape == (5, 1) and ctrl.rewards.shape == (12,)
    assert np.isfinite(ctrl.nominal_knots).all()
    if name == "cmaes":  # carried, not restarted: the generation count went on
        assert opt.variances.shape == (5,) and opt.generation == generation + 4
    if name == "icem":
        assert (
            opt.sigma.shape == (5, 1)
            and opt.mean.shape == (5, 1)
            and opt.kept_elites.shape[1:] == (5, 1)
        )
    ctrl.close()


@pytest.mark.parametrize("name", NEW_OPTIMIZERS)
def test_balances_the_cartpole_with_its_defaults(name):
    """Starting 0.2 rad off upright, the pole stays within 0.45 rad of upright (cos > 0.9) for the
    last second of 3 s, and the cart stays within 0.5 m of the centre, with the task's defaults."""
    ctrl = judo.make_controller("cartpole", name, seed=0)
    plant = type(ctrl.task)()
    plant.config = ctrl.task.config
    plant.data.qpos[:], plant.data.qvel[:] = NEAR_UPRIGHT[:2], NEAR_UPRIGHT[2:]
    mujoco.mj_forward(plant.sim_model, plant.data)
    system = MujocoSystem(plant)
    next_plan, tail = 0.0, []
    while system.read_state().time < 3.0:
        reading = system.read_state()
        if reading.time >= next_plan - 1e-9:
            ctrl.update_action(reading.state, reading.time, reading.metadata)
            next_plan += 1.0 / ctrl.config.control_freq
        system.apply(ctrl.action(reading.time))
        system.step()
        if reading.time >= 2.0:
            tail.append(system.read_state().state.copy())
    ctrl.close()
    tail = np.array(tail)
    assert (np.cos(tail[:, 1]) > 0.9).all(), f"pole fell: min cos {np.cos(tail[:, 1]).min():.2f}"
    assert (np.abs(tail[:, 0]) < 0.5).all(), f"cart drifted to {np.abs(tail[:, 0]).max():.2f} m"


@pytest.mark.parametrize("name", ["cem", "icem", "cmaes"])
def test_controller_reset_restarts_the_search(name):
    ctrl = judo.make_controller("cartpole", name, seed=0)
    opt = ctrl.optimizer
    plan_a_few_cycles(ctrl, 3)
    if name == "cmaes":
        assert opt.generation > 0
    else:
        assert not np.allclose(opt.sigma, opt.config.sigma_max)
    ctrl.reset()
    assert ctrl.nominal_knots is None
    if name == "cmaes":
        assert opt.generation == 0 and not opt.path_sigma.any()
    else:
        np.testing.assert_array_equal(opt.sigma, opt.config.sigma_max)
    ctrl.close()
