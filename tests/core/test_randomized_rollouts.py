"""Randomized rollouts: a mixed-model batch equals each (sequence, model) pair alone, bit for bit;
the hook is seeded and checked; backends that cannot mix models say so."""

import copy

import mujoco
import numpy as np
import pytest

import judo
from judo.core.model import STATE_SPEC
from judo.core.rollouts.backend import RandomizedRolloutError, RolloutBackend
from judo.core.rollouts.randomize import InvalidRandomizedModelError, randomized_models
from judo.core.rollouts.rollout import RolloutPool
from tests.core.test_rollout import sequential_rollouts


def perturbed_copies(model):
    """Two copies of the tiny cart-pole with heavier/lighter bodies and joint damping."""
    heavy, damped = copy.deepcopy(model), copy.deepcopy(model)
    heavy.body_mass[1:] *= [1.7, 0.6]
    damped.dof_damping[:] = [0.5, 0.05]
    return [heavy, damped]


@pytest.mark.parametrize("num_workers", [1, 2, 3])
def test_mixed_model_batch_equals_each_pair_alone_bit_for_bit(tiny_model_path, num_workers):
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    models = [model, *perturbed_copies(model)]
    data = mujoco.MjData(model)
    data.qpos[:] = [0.1, 2.5]
    data.qvel[:] = [0.3, -0.2]
    initial_state = np.zeros(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, initial_state, STATE_SPEC)
    controls = np.random.default_rng(0).uniform(-1, 1, (5, 30, model.nu))  # N = 5 sequences

    pool = RolloutPool(model, num_workers)
    pool.set_models(models)
    # (R * N, T, nstate)
    states, sensors = pool.rollout(initial_state, np.concatenate([controls] * 3))
    states, sensors = states.copy(), sensors.copy()
    pool.set_models(None)
    plain, _ = pool.rollout(initial_state, controls)
    pool.close()

    for r, each in enumerate(models):
        for i in range(len(controls)):
            alone_states, alone_sensors = sequential_rollouts(
                each, initial_state, controls[i : i + 1]
            )
            np.testing.assert_array_equal(states[r * 5 + i], alone_states[0])
            np.testing.assert_array_equal(sensors[r * 5 + i], alone_sensors[0])
    np.testing.assert_array_equal(plain, states[:5])  # None restores the planning model alone
    assert not np.allclose(states[5:10], states[:5]) and not np.allclose(states[10:], states[:5])


def test_pool_refuses_models_of_other_sizes_and_uneven_batches(tiny_model_path):
    model = mujoco.MjModel.from_xml_path(str(tiny_model_path))
    other = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='1'/></body></worldbody></mujoco>"
    )
    pool = RolloutPool(model, 1)
    with pytest.raises(
        RandomizedRolloutError, match="model 1 passed to set_models has nq=7, expected 2"
    ):
        pool.set_models([model, other])
    pool.set_models([model, model])
    with pytest.raises(
        RandomizedRolloutError,
        match="a batch of 5 rollouts cannot be split evenly over the 2 models",
    ):
        pool.rollout(np.zeros(mujoco.mj_stateSize(model, STATE_SPEC)), np.zeros((5, 3, 1)))
    pool.close()


class SingleModelBackend(RolloutBackend):
    """A backend that keeps the base class's set_models: one model only."""

    def __init__(self, model):
        self.model, self.num_workers = model, 1

    def rollout(self, initial_state, controls, mocap=None):
        raise NotImplementedError


def test_backend_without_per_rollout_models_names_itself_and_the_setting(
    tiny_model_path, upright_task
):
    backend = SingleModelBackend(upright_task.model)
    backend.set_models(None)
    backend.set_models([upright_task.model])  # a single model is always fine
    controller = judo.Controller(
        judo.ControllerConfig(num_randomizations=3),
        upright_task,
        judo.make_controller("cartpole", "ps").optimizer,
        num_workers=1,
    )
    controller.backend.close()
    controller.backend = backend
    with pytest.raises(
        RandomizedRolloutError,
        match=r"the SingleModelBackend rollout backend cannot roll out under several models, so it "
        r"cannot run "
        r"num_randomizations = 3; expected num_randomizations = 1",
    ):
        controller.update_action(np.zeros(4), 0.0)


class MassyTask(judo.Task):
    """The tiny upright task whose hook scales the pole's mass by U[0.5, 1.5]."""

    def reward(self, states, sensors, controls, config, system_metadata=None):
        return -(1.0 - np.cos(states[..., 1])).sum(-1)

    def randomize_model(self, model, rng):
        model.body_mass[2] *= rng.uniform(0.5, 1.5)


def test_hook_is_seeded_and_leaves_the_planning_model_alone(tiny_model_path):
    task = MassyTask(tiny_model_path)
    before = task.model.body_mass.copy()
    first = randomized_models(task, 4, np.random.default_rng(7))
    again = randomized_models(task, 4, np.random.default_rng(7))
    other = randomized_models(task, 4, np.random.default_rng(8))
    assert first[0] is task.model
    np.testing.assert_array_equal(task.model.body_mass, before)
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a.body_mass, b.body_mass)
    assert len({float(m.body_mass[2]) for m in first}) == 4  # each copy has its own draw
    assert not np.array_equal(first[1].body_mass, other[1].body_mass)
    # mj_setConst ran
    np.testing.assert_allclose(first[1].body_subtreemass[1], first[1].body_mass[1:].sum())


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda model: model.body_mass.__setitem__(2, -0.1),
            r"BadTask.randomize_model set body_mass\[2\] \(body 'pole'\) to -0.1; "
            r"expected a finite value >= 0 \(it was 0\.1\)",
        ),
        (
            lambda model: model.geom_friction.__setitem__((0, 0), np.nan),
            r"BadTask.randomize_model set geom_friction\[0, 0\] to nan; expected a "
            r"finite value >= 0 \(it was 1\.0\)",
        ),
        (
            lambda model: model.actuator_gainprm.__setitem__((0, 0), np.inf),
            r"set actuator_gainprm\[0, 0\] to inf; expected a finite value \(it was 1\.0\)",
        ),
    ],
)
def test_invalid_model_from_a_hook_names_the_field(tiny_model_path, edit, message):
    class BadTask(MassyTask):
        def randomize_model(self, model, rng):
            edit(model)

    task = BadTask(tiny_model_path)
    with pytest.raises(InvalidRandomizedModelError, match=message):
        randomized_models(task, 2, np.random.default_rng(0))
    optimizer = judo.make_controller("cartpole", "ps").optimizer
    controller = judo.Controller(
        judo.ControllerConfig(num_randomizations=2), task, optimizer, num_workers=1
    )
    with pytest.raises(InvalidRandomizedModelError, match=message):
        controller.update_action(np.zeros(4), 0.0)
    controller.config.num_randomizations = 1  # the user turns it off: planning goes on
    controller.update_action(np.zeros(4), 0.0)
    assert controller.nominal_knots is not None
    controller.close()
