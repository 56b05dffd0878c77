"""Consensus-based optimization (CBO): a swarm of knot sequences that drift to their reward-weighted
consensus, with noise proportional to each particle's distance from it.

R. Pinnau, C. Totzeck, O. Tse, S. Martin, "A consensus-based model for global optimization and its
mean-field limit", Math. Models Methods Appl. Sci. 27(1), 2017, arXiv:1604.05648. J. A. Carrillo, S.
Jin, L. Li, Y. Zhu, "A consensus-based global optimization method for high dimensional machine
learning problems", ESAIM: COCV 27, 2021, arXiv:1909.09249 (the anisotropic, per-coordinate noise).
"""

from dataclasses import dataclass

import numpy as np

from judo.core.configuration.config import require, require_between
from judo.core.configuration.fields import slider
from judo.core.optimizer import Optimizer, OptimizerConfig, weighted_knots
from judo.optimizers.knot_shift import shift_knots
from judo.optimizers.mppi import softmax_weights


@slider("num_rollouts", 2, 512, 1)  # the plan and at least one particle
@slider("sigma", 0.001, 2.0, 0.001)
@slider("sigma_min", 0.0, 2.0, 0.001)
@slider("temperature", 0.001, 10.0, 0.001)
@slider("drift", 0.0, 10.0, 0.1)
@slider("noise", 0.0, 5.0, 0.05)
@slider("step_size", 0.01, 1.0, 0.01)
@dataclass
class CBOConfig(OptimizerConfig):
    """CBO settings: the swarm's initial spread, the consensus weighting, and the particles' SDE."""

    sigma: float = 0.3
    """Std of the Gaussian the particles start from around the plan (and a new particle, after a
    num_rollouts edit)."""
    sigma_min: float = 0.1
    """Std of a noise every particle gets on top of the SDE's, so the swarm never collapses onto its
    consensus while the MPC problem moves from cycle to cycle (0: the plain SDE)."""
    temperature: float = 0.1
    """Softmax temperature on rewards for the consensus (1 / alpha in the papers): small follows the
    best particle."""
    drift: float = 1.0
    """Drift rate lambda towards the consensus, per unit of SDE time."""
    noise: float = 1.0
    """Diffusion sigma: each coordinate's noise std is noise * |x - consensus| * sqrt(step_size)."""
    step_size: float = 0.5
    """Euler-Maruyama time step dt of the SDE per iteration."""

    def validate(self) -> None:
        super().validate()
        require(
            self.num_rollouts >= 2,
            f"CBO needs num_rollouts >= 2 (the plan plus a particle), got {self.num_rollouts}",
        )
        require(self.sigma > 0, f"sigma must be positive, got {self.sigma}")
        require(self.sigma_min >= 0, f"sigma_min must be non-negative, got {self.sigma_min}")
        require(self.temperature > 0, f"temperature must be positive, got {self.temperature}")
        require_between("drift", self.drift, 0, 100)
        require_between("noise", self.noise, 0, 100)
        require_between("step_size", self.step_size, 0, 1, above=True)


class CBO(Optimizer[CBOConfig]):
    """Consensus-based optimization over knot sequences: num_rollouts - 1 particles and the plan.

    Each iteration evaluates the plan (row 0, the nominal) and the particles x_i (rows 1...). The
    consensus is the softmax-weighted mean, as MPPI's, over all of them; it becomes the new plan.
    Each particle then takes one Euler-Maruyama step of the anisotropic CBO SDE dx = -lambda (x - c)
    dt + sigma |x - c| dB:

        c = sum_j w_j x_j,  w = softmax(rewards / temperature)
        x_i <- x_i - drift * step_size * (x_i - c)
                   + sqrt(noise^2 step_size (x_i - c)^2 + sigma_min^2) * xi_i,   xi_i ~ N(0, I)

    (products per coordinate). The particles are the knots the rollouts applied, clamped to the
    actuator limits, with a proposal policy's candidates in their rows, so a proposal joins the
    swarm. A particle that scored -inf has zero weight and is drawn towards the consensus like the
    others.

    Unlike the papers: `sigma_min` adds a floor to the noise (the plain SDE stops exploring once the
    swarm has agreed, but an MPC problem changes every cycle); the swarm lives across planning
    cycles, shifted to the new knot times with the plan, so one iteration per cycle goes on where
    the last one stopped. A num_rollouts edit drops particles or adds new ones around the plan; a
    num_nodes edit re-interpolates them.

    Attributes:
        particles: (num_rollouts - 1, num_nodes, nu) the swarm to evaluate next, or None until the
            first sample.
    """

    def __init__(self, config: CBOConfig, nu: int) -> None:
        super().__init__(config, nu)
        self.restart()

    def restart(self) -> None:
        """Forget the swarm; the next sample draws a new one around the plan."""
        self.particles: np.ndarray | None = None

    def pre_optimization(self, old_times: np.ndarray, new_times: np.ndarray) -> None:
        if self.particles is None:
            return
        # a swarm that does not belong to the old plan
        if self.particles.shape[1] != len(old_times):
            self.restart()
            return
        self.particles = shift_knots(self.particles, old_times, new_times)

    def sample_control_knots(self, nominal_knots: np.ndarray) -> np.ndarray:
        count = self.num_rollouts - 1
        if self.particles is not None and self.particles.shape[1:] != nominal_knots.shape:
            self.restart()  # sizes changed without pre_optimization
        kept = (
            np.zeros((0, *nominal_knots.shape))
            if self.particles is None
            else self.particles[:count]
        )
        samples = np.empty((self.num_rollouts, self.num_nodes, self.nu))
        samples[0] = nominal_knots
        samples[1 : 1 + len(kept)] = kept
        fresh = samples[1 + len(kept) :]
        self.rng.standard_normal(out=fresh)
        fresh *= self.config.sigma * self.noise_ramp_scale()
        fresh += nominal_knots
        return samples

    def update_nominal_knots(self, sampled_knots: np.ndarray, rewards: np.ndarray) -> np.ndarray:
        cfg = self.config
        weights = softmax_weights(rewards, cfg.temperature)
        consensus = weighted_knots(weights, sampled_knots)
        deviation = sampled_knots[1:] - consensus
        spread = np.sqrt(cfg.noise**2 * cfg.step_size * np.square(deviation) + cfg.sigma_min**2)
        self.particles = (
            sampled_knots[1:]
            - cfg.drift * cfg.step_size * deviation
            + spread * self.rng.standard_normal(deviation.shape)
        )
        return consensus
