"""`python -m judo excite`: drive a task's plant with a band-limited excitation and log it for sysid (docs/sysid.md).

python -m judo excite --task cartpole --duration 60 --out excite.h5
python -m judo sysid excite.h5 --task cartpole --params body_mass.pole dof_damping.slider --out fitted.toml

Each actuator gets a multisine: components at frequencies spread evenly up to --bandwidth Hz, with random phases
(seeded), scaled so that the signal spans --amplitude of the actuator's control range about its centre and never
leaves the range. The plant is judo's simulator with the task's plant overrides (--plant-overrides, --config);
the log has collect's layout, so `sysid` reads it.
"""

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import tyro

from judo.cli_shared import apply_config_file, fail, parse_args
from judo.core.boundary import check_output_file, require
from judo.core.errors import ConfigError, JudoError

if TYPE_CHECKING:
    import mujoco

    from judo.collection.dataset import EpisodeArrays

DESCRIPTION = (
    "Drive a task's simulated plant open loop with a safe band-limited excitation (a multisine per actuator within "
    "its control range) and log it in collect's HDF5 layout for python -m judo sysid. Needs the `collect` extra."
)
NUM_COMPONENTS = 8
"""Sines per actuator."""


@dataclass
class ExciteArgs:
    """The task, the plant, the excitation and where the log goes."""

    task: Annotated[str, tyro.conf.arg(metavar="NAME")] = field(kw_only=True)
    """The task whose plant is excited, by registered name."""
    out: Annotated[Path, tyro.conf.arg(metavar="LOG.h5")] = field(kw_only=True)
    """The HDF5 log to write (collect's layout)."""
    config: Annotated[Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")] = None
    """TOML file that registers a custom task or sets its [plant_overrides]."""
    plant_overrides: Annotated[tuple[str, ...], tyro.conf.arg(metavar="FIELD.ELEMENT=VALUE")] = ()
    """MjModel fields of the simulated plant, by element name, e.g. body_mass.pole=0.13."""
    duration: float = 30.0
    """Seconds of excitation."""
    amplitude: float = 0.5
    """Share of each actuator's control range the excitation spans, about the range's centre (0 to 1)."""
    bandwidth: float = 2.0
    """Highest frequency (Hz) in the excitation."""
    seed: int = 0
    """Seeds the phases and the plant's start state."""

    def validate(self) -> None:
        """Raise a JudoError (one line) for an argument that is wrong, before anything is run or written."""
        require(self.out.suffix in (".h5", ".hdf5"), f"--out must name an .h5 file, got {str(self.out)!r}")
        require(math.isfinite(self.duration) and self.duration > 0, f"--duration must be > 0, got {self.duration}")
        require(0 < self.amplitude <= 1, f"--amplitude must be in (0, 1], got {self.amplitude}")
        require(
            math.isfinite(self.bandwidth) and self.bandwidth > 0, f"--bandwidth must be > 0 Hz, got {self.bandwidth}"
        )
        check_output_file("--out", self.out)


def multisine(ranges: np.ndarray, times: np.ndarray, amplitude: float, bandwidth: float, seed: int) -> np.ndarray:
    """(S, nu) controls at `times` (S,): per actuator a sum of NUM_COMPONENTS sines up to `bandwidth` Hz with random
    phases, normalised to peak 1, times `amplitude` of half its range (`ranges` (nu, 2)) about the centre."""
    rng = np.random.default_rng(seed)
    frequencies = np.linspace(bandwidth / NUM_COMPONENTS, bandwidth, NUM_COMPONENTS)
    centre, half = ranges.mean(axis=1), (ranges[:, 1] - ranges[:, 0]) / 2
    phases = rng.uniform(0, 2 * np.pi, (len(ranges), NUM_COMPONENTS))
    waves = np.sin(2 * np.pi * frequencies[None, None, :] * times[:, None, None] + phases[None]).sum(-1)
    waves /= np.maximum(np.abs(waves).max(axis=0), 1e-12)
    return np.clip(centre + amplitude * half * waves, ranges[:, 0], ranges[:, 1])


def excitation_episode(
    seed: int,
    model: "mujoco.MjModel",
    states: np.ndarray,
    sensors: np.ndarray,
    controls: np.ndarray,
    mocap_pos: np.ndarray | None = None,
) -> "EpisodeArrays":
    """An open-loop episode in collect's layout (no plans): `states` (S, nq + nv) after each step, `sensors`
    (S, nsensordata), `controls` (S, nu) served during each step, and `mocap_pos` (nmocap * 3,) held throughout."""
    from judo.collection.dataset import EpisodeArrays

    steps = len(states)
    empty = np.zeros(0)
    plan = {"times": empty, "takes_effect": empty, "update_ms": empty, "best_reward": empty, "mean_reward": empty}
    return EpisodeArrays(
        seed,
        states[:, : model.nq],
        states[:, model.nq :],
        sensors,
        None if mocap_pos is None else np.tile(mocap_pos, (steps, 1)),
        controls,
        np.zeros(steps),
        {**plan, "knots": np.zeros((0, 1, model.nu))},
        {},
        None,
    )


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo excite` on `argv` (sys.argv[1:] when None); exits with status 2 on bad arguments."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(ExciteArgs, argv, "python -m judo excite", DESCRIPTION)
    try:
        args.validate()
        apply_config_file(args.config)
        run(args)
    except JudoError as err:
        fail(str(err))
    return 0


def run(args: ExciteArgs) -> None:
    """Excite the plant and write the log."""
    from judo.collection.dataset import DatasetFile
    from judo.core.model_overrides import parse_override_entries
    from judo.core.registry import make_task, set_model_overrides
    from judo.loop.system import MujocoSystem

    if args.plant_overrides:
        set_model_overrides(args.task, parse_override_entries(args.plant_overrides), plant=True)
    task = make_task(args.task)
    model = task.sim_model
    unlimited = [i for i in range(model.nu) if not model.actuator_ctrllimited[i]]
    if unlimited:
        name = model.actuator(unlimited[0]).name or f"#{unlimited[0]}"
        raise ConfigError(
            f"actuator {name} of {args.task} has no ctrlrange; excite stays within each actuator's limits"
        )
    system = MujocoSystem.from_task(task, args.seed)
    steps = round(args.duration / system.timestep)
    controls = multisine(
        model.actuator_ctrlrange, np.arange(steps) * system.timestep, args.amplitude, args.bandwidth, args.seed
    )
    states = np.zeros((steps, model.nq + model.nv))
    sensors = np.zeros((steps, model.nsensordata))
    for step, control in enumerate(controls):
        system.apply(control)
        system.step()
        states[step] = system.plant_state()
        sensors[step] = system.plant_sensors()
    mocap = None if not model.nmocap else system.task.data.mocap_pos.reshape(-1)
    episode = excitation_episode(args.seed, model, states, sensors, controls, mocap)
    excitation = {"amplitude": args.amplitude, "bandwidth_hz": args.bandwidth, "duration": args.duration}
    env_args = {"task": args.task, "excite": excitation, "plant_timestep": float(model.opt.timestep)}
    DatasetFile(args.out, env_args).write_episode(episode)
    print(f"wrote {steps} steps of excitation of {args.task} to {args.out}")
