"""The cart-pole reward's fast elementwise form equals the plain formula written with the norm
helpers."""

import numpy as np

import judo
from judo.tasks.cartpole import Cartpole, CartpoleConfig


def reference_reward(states, controls, config):
    angle, cart_x, velocities = states[..., 1:2], states[..., 0:1], states[..., 2:4]
    return -(
        config.w_vertical * judo.smooth_l1_norm(np.cos(angle) - 1.0, 0.01).sum(-1)
        + config.w_centered * judo.smooth_l1_norm(cart_x, 0.1).sum(-1)
        + config.w_velocity * judo.quadratic_norm(velocities).sum(-1)
        + config.w_control * judo.quadratic_norm(controls).sum(-1)
    )


def test_fast_reward_matches_the_reference_and_prefers_upright():
    rng = np.random.default_rng(0)
    states, controls = rng.normal(size=(8, 30, 4)), rng.normal(size=(8, 30, 1))
    config = CartpoleConfig(w_vertical=3.0, w_centered=2.0, w_velocity=0.5, w_control=0.2)
    task = Cartpole()
    np.testing.assert_allclose(
        task.reward(states, None, controls, config), reference_reward(states, controls, config)
    )
    upright, hanging = np.zeros((1, 30, 4)), np.zeros((1, 30, 4))
    hanging[..., 1] = np.pi
    zero = np.zeros((1, 30, 1))
    assert (
        task.reward(upright, None, zero, config)[0]
        == 0.0
        > task.reward(hanging, None, zero, config)[0]
    )
