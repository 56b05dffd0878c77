"""`TrainSettings`: how distill trains; each field is a `distill` flag (judo.learning.args)."""

from dataclasses import dataclass
from typing import Literal


@dataclass
class TrainSettings:
    """How distill trains (each is a `distill` flag)."""

    head: Literal["regression", "flow"] = "regression"
    """Output head: regression (deterministic) or flow (flow matching, multimodal)."""
    hidden: tuple[int, ...] = (256, 256)
    """Widths of the hidden layers."""
    epochs: int = 300
    """Most passes over the training pairs."""
    batch_size: int = 256
    """Pairs per gradient step."""
    learning_rate: float = 1e-3
    """Adam's step size."""
    patience: int = 30
    """Epochs without a lower validation loss before training stops."""
    validation_fraction: float = 0.2
    """Share of the episodes held out for validation (at least one, when there are two or more)."""
    flow_steps: int = 10
    """Euler steps of the flow head's sampler."""
    seed: int = 0
    """Seeds the split, the initial weights, the minibatches and the flow's noise."""
