"""The controller under randomized models: R = 1 is today's plan bit for bit, R models reduce by the
risk measure, the models are seeded and redrawn on schedule, and the settings are validated."""

import mujoco
import numpy as np
import pytest

import judo
from judo.core.model import STATE_SPEC
from judo.core.rollouts.rollout import RolloutPool
from judo.core.spline import SplineBasis
from judo.optimizers.ps import PredictiveSampling, PredictiveSamplingConfig
from tests.core.test_randomized_rollouts import MassyTask


def ps_optimizer(nu, seed=0):
    optimizer = PredictiveSampling(
        PredictiveSamplingConfig(num_rollouts=8, num_nodes=4, sigma=0.5), nu
    )
    optimizer.rng = np.random.default_rng(seed)
    return optimizer


def reference_plan(task, state, iterations):
    """Plain loop without randomization: sample, clamp, interpolate, roll out, score, update (one
    cycle)."""
    optimizer = ps_optimizer(task.nu)
    config = judo.ControllerConfig(horizon=0.3, max_opt_iters=iterations)
    offsets = np.linspace(0.0, config.horizon, optimizer.num_nodes)
    weights = SplineBasis(offsets, config.spline_order).weights(
        np.arange(round(config.horizon / task.dt)) * task.dt
    )
    data = mujoco.MjData(task.model)
    data.qpos[:], data.qvel[:] = state[: task.model.nq], state[task.model.nq :]
    initial = np.zeros(mujoco.mj_stateSize(task.model, STATE_SPEC))
    mujoco.mj_getState(task.model, data, initial, STATE_SPEC)
    pool = RolloutPool(task.model, 2)
    nominal = np.zeros((optimizer.num_nodes, task.nu))
    optimizer.pre_optimization(offsets, offsets)
    low, high = task.actuator_ctrlrange.T
    for _ in range(iterations):
        knots = np.clip(optimizer.sample_control_knots(nominal), low, high)
        controls = weights @ knots
        states, sensors = pool.rollout(initial, controls, np.zeros(0))
        rewards = task.reward(states[..., 1:], sensors, controls, task.config)
        nominal = optimizer.update_nominal_knots(knots, rewards)
    pool.close()
    return np.clip(nominal, low, high)


def test_one_randomization_is_todays_plan_bit_for_bit(tiny_model_path):
    state = np.array([0.05, 0.4, 0.0, -0.3])
    task = MassyTask(tiny_model_path)
    controller = judo.Controller(
        judo.ControllerConfig(horizon=0.3, max_opt_iters=3, num_randomizations=1, risk="worst"),
        task,
        ps_optimizer(task.nu),
        num_workers=2,
    )
    controller.update_action(state, 0.0)
    controller.close()
    np.testing.assert_array_equal(
        controller.nominal_knots, reference_plan(MassyTask(tiny_model_path), state, 3)
    )
    assert len(controller.models) == 1 and controller.models[0] is task.model


def test_identical_models_averaged_give_the_single_model_plan(upright_task, tiny_model_path):
    """With the no-op hook every model is the planning model, so (r + r) / 2 = r: the same plan,
    which checks that block r of the batch is every sequence under model r, in order."""
    plans = []
    for num_models in (1, 2):
        config = judo.ControllerConfig(horizon=0.3, max_opt_iters=2, num_randomizations=num_models)
        controller = judo.Controller(
            config, type(upright_task)(tiny_model_path), ps_optimizer(1), 2
        )
        for step in range(3):
            controller.update_action(np.array([0.0, 0.3, 0.0, 0.0]), 0.05 * step)
        plans.append(
            (controller.nominal_knots.copy(), controller.rewards.copy(), controller.traces.copy())
        )
        controller.close()
    for single, double in zip(*plans, strict=True):
        np.testing.assert_array_equal(single, double)


def test_rewards_are_reduced_by_the_risk_measure(tiny_model_path):
    seen = {}

    class Recording(MassyTask):
        def reward(self, states, sensors, controls, config, system_metadata=None):
            seen["rewards"] = super().reward(states, sensors, controls, config, system_metadata)
            seen["controls"] = controls.copy()
            return seen["rewards"]

    for risk, reduce in (("worst", np.min), ("best", np.max), ("average", np.mean)):
        config = judo.ControllerConfig(horizon=0.3, num_randomizations=3, risk=risk)
        controller = judo.Controller(config, Recording(tiny_model_path), ps_optimizer(1), 2)
        controller.update_action(np.array([0.0, 0.3, 0.0, 0.0]), 0.0)
        controller.close()
        per_model = seen["rewards"].reshape(3, 8).T  # (num_rollouts, R)
        np.testing.assert_array_equal(controller.rewards, reduce(per_model, axis=1))
        # each sequence once per model
        np.testing.assert_array_equal(seen["controls"][:8], seen["controls"][8:16])
        assert not np.array_equal(per_model[:, 0], per_model[:, 1])  # the models really differ
        assert controller.traces.shape[0] == 1 + 5


def test_models_are_seeded_by_the_task_generator_and_redrawn_on_schedule(tiny_model_path):
    def pole_masses(seed, redraw_every, cycles):
        task = MassyTask(tiny_model_path)
        task.rng = np.random.default_rng(seed)
        config = judo.ControllerConfig(horizon=0.3, num_randomizations=3, redraw_every=redraw_every)
        controller = judo.Controller(config, task, ps_optimizer(1), 2)
        masses = []
        for step in range(cycles):
            controller.update_action(np.zeros(4), 0.05 * step)
            masses.append(tuple(float(m.body_mass[2]) for m in controller.models))
        controller.close()
        return masses

    kept = pole_masses(3, 0, 4)
    assert kept == pole_masses(3, 0, 4) and kept != pole_masses(4, 0, 4)
    assert len(set(kept)) == 1 and kept[0][0] == 0.1  # drawn once; model 0 is the planning model
    redrawn = pole_masses(3, 2, 5)
    assert (
        redrawn[0] == redrawn[1] == kept[0]
        and redrawn[2] == redrawn[3] != redrawn[1]
        and redrawn[4] != redrawn[3]
    )


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"num_randomizations": 0}, "num_randomizations must be between 1 and 64, got 0"),
        ({"cvar_alpha": 0.0}, "cvar_alpha must be in (0, 1], got 0.0"),
        ({"cvar_alpha": 1.5}, "cvar_alpha must be in (0, 1], got 1.5"),
        (
            {"risk_scale": 0.0},
            "risk_scale must be a finite nonzero number (> 0 risk-averse, < 0 "
            "risk-seeking), got 0.0",
        ),
        ({"redraw_every": -1}, "redraw_every must be at least 0 (0: draw once), got -1"),
    ],
)
def test_settings_are_validated_with_clear_messages(fields, message):
    with pytest.raises(judo.ConfigError) as raised:
        judo.ControllerConfig(**fields)
    assert str(raised.value) == message


def test_risk_choices_are_listed():
    from judo.core.configuration.config import with_updates

    with pytest.raises(
        judo.ConfigError,
        match=r"ControllerConfig.risk expects one of \['average', 'worst', 'best', 'cvar', "
        r"'exponential'\], got 'mean'",
    ):
        with_updates(judo.ControllerConfig(), {"risk": "mean"})
