"""Training a policy on TrainingPairs: split by episode, normalize, Adam in minibatches, stop early.

The validation episodes are never trained on; the parameters kept are those of the epoch with the
lowest validation loss, and training stops once `patience` epochs passed without a new lowest. JAX
and optax are imported when `train` runs (the judo-mpc[learn] extra).
"""

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from judo.core.errors import import_extra
from judo.learning.pairs import DistillError, TrainingPairs
from judo.learning.settings import TrainSettings

EXTRA = "learn"


@dataclass
class TrainedPolicy:
    """A trained network and what it needs to run: numpy parameters and the normalization.

    Attributes:
        layers: [(W (out, in), b (out,))] float32.
        input_scale: (mean (O,), std (O,)) of the training observations.
        output_scale: (mean (D,), std (D,)) of the training targets.
        head, flow_steps, horizon, action_size: the head, its sampler's steps, and the target's H x
            A.
        history: {"train": [...], "validation": [...]} the loss after each epoch.
        best_epoch: the epoch whose parameters were kept.
        train_episodes, validation_episodes: the episodes of each side of the split.
        seconds: wall time of training.
    """

    layers: list[tuple[np.ndarray, np.ndarray]]
    input_scale: tuple[np.ndarray, np.ndarray]
    output_scale: tuple[np.ndarray, np.ndarray]
    head: str
    flow_steps: int
    horizon: int
    action_size: int
    history: dict[str, list[float]] = field(default_factory=lambda: {"train": [], "validation": []})
    best_epoch: int = 0
    train_episodes: list[str] = field(default_factory=list)
    validation_episodes: list[str] = field(default_factory=list)
    seconds: float = 0.0

    def act(self, observations: np.ndarray, noise: np.ndarray | None = None) -> np.ndarray:
        """(B, O) observations -> (B, H * A) targets through JAX (the reference the ONNX export is
        checked against); the flow starts from `noise` (B, D), zeros when None."""
        import jax.numpy as jnp

        from judo.learning.networks import predict

        mean, std = self.input_scale
        normalized = (np.asarray(observations, np.float32) - mean) / std
        start = (
            np.zeros((len(normalized), len(self.output_scale[0])), np.float32)
            if noise is None
            else noise
        )
        params = [(jnp.asarray(w), jnp.asarray(b)) for w, b in self.layers]
        out = np.asarray(
            predict(params, self.head, jnp.asarray(normalized), jnp.asarray(start), self.flow_steps)
        )
        return out * self.output_scale[1] + self.output_scale[0]


def split_episodes(num_episodes: int, fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(train indices, validation indices) of the episodes, shuffled by `seed`: at least one of each
    side when there are two or more episodes; with one, it trains and validates on it."""
    order = np.random.default_rng(seed).permutation(num_episodes)
    if num_episodes < 2:
        return order, order
    held = min(num_episodes - 1, max(1, round(fraction * num_episodes)))
    return order[held:], order[:held]


def scale_of(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mean (D,), std (D,)) float32 of (n, D) rows; a column that never changes gets std 1."""
    mean, std = rows.mean(axis=0), rows.std(axis=0)
    return mean.astype(np.float32), np.where(std > 1e-6, std, 1.0).astype(np.float32)


def train(
    pairs: TrainingPairs,
    settings: TrainSettings,
    on_epoch: Callable[[int, float, float], None] | None = None,
) -> TrainedPolicy:
    """Train `settings.head` on `pairs`; `on_epoch(epoch, train_loss, validation_loss)` after each
    epoch."""
    jax = import_extra("jax", "python -m judo distill", EXTRA)
    optax = import_extra("optax", "python -m judo distill", EXTRA)
    import jax.numpy as jnp

    from judo.learning import networks

    if settings.head not in networks.HEADS:
        raise DistillError(f"unknown head {settings.head!r}; choose one of {list(networks.HEADS)}")
    started = time.perf_counter()
    train_ids, val_ids = split_episodes(
        len(pairs.observations), settings.validation_fraction, settings.seed
    )
    obs_train = np.concatenate([pairs.observations[i] for i in train_ids])
    tgt_train = np.concatenate([pairs.targets[i] for i in train_ids])
    input_scale, output_scale = scale_of(obs_train), scale_of(tgt_train)

    def normalized(ids: np.ndarray) -> tuple:
        obs = np.concatenate([pairs.observations[i] for i in ids])
        tgt = np.concatenate([pairs.targets[i] for i in ids])
        return (
            jnp.asarray((obs - input_scale[0]) / input_scale[1], jnp.float32),
            jnp.asarray((tgt - output_scale[0]) / output_scale[1], jnp.float32),
        )

    (x_train, y_train), (x_val, y_val) = normalized(train_ids), normalized(val_ids)
    obs_size, target_size = x_train.shape[1], y_train.shape[1]
    sizes = [
        networks.input_size(settings.head, obs_size, target_size),
        *settings.hidden,
        target_size,
    ]
    key = jax.random.PRNGKey(settings.seed)
    key, init_key, val_key = jax.random.split(key, 3)
    params = networks.init_mlp(init_key, sizes)
    optimizer = optax.adam(settings.learning_rate)
    state = optimizer.init(params)
    head = settings.head

    @jax.jit
    def step(params, state, x, y, key):
        value, grads = jax.value_and_grad(networks.loss)(params, head, x, y, key)
        updates, state = optimizer.update(grads, state, params)
        return optax.apply_updates(params, updates), state, value

    evaluate = jax.jit(lambda params, x, y: networks.loss(params, head, x, y, val_key))
    result = TrainedPolicy(
        [], input_scale, output_scale, head, settings.flow_steps, pairs.horizon, pairs.action_size
    )
    result.train_episodes = [pairs.episodes[i] for i in train_ids]
    result.validation_episodes = [pairs.episodes[i] for i in val_ids]
    rng = np.random.default_rng(settings.seed)
    n, batch = len(x_train), min(settings.batch_size, len(x_train))
    best, best_params, since_best = np.inf, params, 0
    for epoch in range(settings.epochs):
        order = rng.permutation(n)
        losses = []
        for start in range(0, n - batch + 1, batch):
            key, batch_key = jax.random.split(key)
            index = order[start : start + batch]
            params, state, value = step(params, state, x_train[index], y_train[index], batch_key)
            losses.append(float(value))
        val_loss = float(evaluate(params, x_val, y_val))
        result.history["train"].append(float(np.mean(losses)))
        result.history["validation"].append(val_loss)
        if on_epoch is not None:
            on_epoch(epoch, result.history["train"][-1], val_loss)
        if val_loss < best:
            best, best_params, since_best, result.best_epoch = val_loss, params, 0, epoch
        else:
            since_best += 1
            if since_best >= settings.patience:
                break
    if not np.isfinite(best):
        raise DistillError(
            "training diverged: the validation loss is not finite; try a lower --learning-rate"
        )
    result.layers = [(np.asarray(w, np.float32), np.asarray(b, np.float32)) for w, b in best_params]
    result.seconds = time.perf_counter() - started
    return result
