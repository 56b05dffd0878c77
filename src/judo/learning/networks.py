"""The networks distill trains, in JAX: an MLP, and two heads on it.

  - "regression": the MLP maps the normalized observation (O,) to the normalized target (D,) = (H *
    A,); trained on the mean squared error. Deterministic: one action (or chunk) per observation.
  - "flow" (flow matching, as gpc uses): the MLP is a velocity field v(o, x, t) on [o, x, t] (O + D
    + 1,) -> (D,). Trained on ||v(o, x_t, t) - (x_1 - x_0)||^2 with x_0 ~ N(0, I), x_1 the
    normalized target and x_t = (1 - t) x_0 + t x_1; sampled by `flow_steps` Euler steps from x_0 =
    noise_scale * N(0, I). It can give several modes for one observation (push the T from either
    side) where regression averages them.

Parameters are [(W (out, in), b (out,))] per layer, the layout
`judo.core.policies.onnx_policy.mlp_policy_model` writes, with ELU between layers (ONNX "Elu", alpha
1). JAX is imported by this module: import it only to train.
"""

from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np

HEADS = ("regression", "flow")
"""The output heads distill can train."""
ACTIVATION = "Elu"
"""The ONNX op between layers; `jax.nn.elu` here."""

Params = list[tuple[jax.Array, jax.Array]]


def init_mlp(key: jax.Array, sizes: Sequence[int]) -> Params:
    """[(W (sizes[i + 1], sizes[i]), b (sizes[i + 1],))] with scaled normal weights and zero biases;
    the last layer starts small so the first outputs are near the target's mean."""
    params = []
    keys = jax.random.split(key, len(sizes) - 1)
    for i, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:], strict=True)):
        scale = np.sqrt(2.0 / fan_in) * (0.01 if i == len(sizes) - 2 else 1.0)
        params.append((scale * jax.random.normal(keys[i], (fan_out, fan_in)), jnp.zeros(fan_out)))
    return params


def mlp(params: Params, x: jax.Array) -> jax.Array:
    """(B, in) -> (B, out): ELU between the layers, none after the last."""
    for weight, bias in params[:-1]:
        x = jax.nn.elu(x @ weight.T + bias)
    weight, bias = params[-1]
    return x @ weight.T + bias


def input_size(head: str, observation_size: int, target_size: int) -> int:
    """The MLP's input width: O for regression, O + D + 1 for the flow's velocity field."""
    return observation_size if head == "regression" else observation_size + target_size + 1


def loss(
    params: Params, head: str, observations: jax.Array, targets: jax.Array, key: jax.Array
) -> jax.Array:
    """The mean loss of a (B, O) normalized observation and (B, D) normalized target batch; `key`
    draws the flow's noise and times (unused by regression)."""
    if head == "regression":
        return jnp.mean((mlp(params, observations) - targets) ** 2)
    noise_key, time_key = jax.random.split(key)
    x0 = jax.random.normal(noise_key, targets.shape)
    t = jax.random.uniform(time_key, (targets.shape[0], 1))
    xt = (1.0 - t) * x0 + t * targets
    velocity = mlp(params, jnp.concatenate([observations, xt, t], axis=1))
    return jnp.mean((velocity - (targets - x0)) ** 2)


def predict(
    params: Params, head: str, observations: jax.Array, noise: jax.Array, flow_steps: int
) -> jax.Array:
    """(B, D) normalized targets for (B, O) normalized observations: the regression's output, or the
    flow's Euler integration from `noise` (B, D) (scaled already; zeros give the deterministic
    sample)."""
    if head == "regression":
        return mlp(params, observations)
    x = noise
    column = jnp.ones((observations.shape[0], 1))
    for k in range(flow_steps):
        x = (
            x
            + mlp(params, jnp.concatenate([observations, x, column * (k / flow_steps)], axis=1))
            / flow_steps
        )
    return x
