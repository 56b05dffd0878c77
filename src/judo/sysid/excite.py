"""`python -m judo excite`: drive a task's plant with a band-limited excitation and log it for sysid
(docs/sysid.md).

python -m judo excite --task cartpole --duration 60 --out excite.h5
python -m judo excite --task cartpole --duration 60 --out robot.h5 --system my_robot:MyRobot   # your own System
python -m judo sysid excite.h5 --task cartpole --params body_mass.pole dof_damping.slider --out fitted.toml

Each actuator gets a multisine: components at frequencies spread evenly up to --bandwidth Hz, with
random phases (seeded), scaled so that the signal spans --amplitude of the actuator's control range
about its centre and never leaves the range. The plant is judo's simulator with the task's plant
overrides (--plant-overrides, --config), or the System --system names (as the app's --system: ros2
or module:Class), whose step() is called once per timestep of wall clock, paced by the app's plant
clock (judo.loop.timing); judo's simulator, which has no wall clock of its own, is stepped as
fast as it goes, as collect steps it. What the plant reports is logged: its state where it gives
one, its sensors, and, where its readings hold only measured sensors, those sensors, when each was
taken, and the task's default estimator's state (what `sysid` starts each window from). At the end,
or on Ctrl-C or SIGTERM, the plant is brought to rest (its halt(), else the task's safe action) and
what was logged is written. The log has collect's layout, so `sysid` reads it.
"""  # noqa: E501

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import tyro
from rich.progress import BarColumn, MofNCompleteColumn, TextColumn

from judo.cli_shared import apply_config_file, fail, parse_args, progress_display
from judo.core.commandline.boundary import check_output_file
from judo.core.configuration.config import require
from judo.core.errors import ConfigError, JudoError
from judo.sysid.drive import drive

if TYPE_CHECKING:
    import mujoco

    from judo.loop.system import System
    from judo.recording.dataset import EpisodeArrays
    from judo.sysid.drive import Measurements

DESCRIPTION = (
    "Drive a task's plant open loop with a safe band-limited excitation (a multisine per "
    "actuator within its "
    "control range) and log it in collect's HDF5 layout for python -m judo sysid: judo's "
    "simulator, or your own "
    "System (--system module:Class, or ros2). What the plant reports is logged: its state, "
    "or its measured sensors "
    "with the task's default estimator's state. Ctrl-C stops it, brings the plant to rest "
    "(its halt(), else the "
    "task's safe action) and keeps what was logged. Needs the `collect` extra."
)
NUM_COMPONENTS = 8
"""Sines per actuator."""
MAX_DURATION = 3600.0
"""Most seconds of excitation (--duration): an hour; sysid fits a few minutes."""
MAX_STEPS = 400_000
"""Most steps of excitation (--duration / the plant's timestep): what the log holds in memory until
it is written."""


@dataclass
class ExciteArgs:
    """The task, the plant, the excitation and where the log goes."""

    task: Annotated[str, tyro.conf.arg(metavar="NAME")] = field(kw_only=True)
    """The task whose plant is excited, by registered name."""
    out: Annotated[Path, tyro.conf.arg(metavar="LOG.h5")] = field(kw_only=True)
    """The HDF5 log to write (collect's layout)."""
    config: Annotated[
        Path | None, tyro.conf.arg(metavar="PATH", help_behavior_hint="(optional)")
    ] = None
    """TOML file that registers a custom task or sets its [plant_overrides]."""
    plant_overrides: Annotated[tuple[str, ...], tyro.conf.arg(metavar="FIELD.ELEMENT=VALUE")] = ()
    """MjModel fields of the simulated plant, by element name, e.g. body_mass.pole=0.13 (judo's
    simulator only)."""
    system: Annotated[str | None, tyro.conf.arg(metavar="NAME")] = None
    """The plant driven: sim (judo's simulator, the default); ros2 (a robot through the ROS 2
    bridge, needs pip install -e ".[ros2]"); or module:Class, your own System subclass, built with
    Class(task) as the app builds it (module found on the Python path, e.g. the current folder). Its
    actions stay within the planning model's ctrlrange."""
    duration: float = 30.0
    """Seconds of excitation."""
    amplitude: float = 0.5
    """Share of each actuator's control range the excitation spans, about the range's centre (0 to
    1)."""
    bandwidth: float = 2.0
    """Highest frequency (Hz) in the excitation."""
    seed: int = 0
    """Seeds the phases and the plant's start state (>= 0)."""

    def validate(self) -> None:
        """Raise a JudoError (one line) for an argument that is wrong, before anything is run or
        written."""
        require(
            self.out.suffix in (".h5", ".hdf5"),
            f"--out must name an .h5 file, got {str(self.out)!r}",
        )
        require(
            0 < self.duration <= MAX_DURATION,
            f"--duration must be in (0, {MAX_DURATION:g}] s (at most an hour of excitation), "
            f"got {self.duration}",
        )
        require(0 < self.amplitude <= 1, f"--amplitude must be in (0, 1], got {self.amplitude}")
        require(
            math.isfinite(self.bandwidth) and self.bandwidth > 0,
            f"--bandwidth must be > 0 Hz, got {self.bandwidth}",
        )
        require(self.seed >= 0, f"--seed must be >= 0, got {self.seed}")
        check_output_file("--out", self.out)


def multisine(
    ranges: np.ndarray, times: np.ndarray, amplitude: float, bandwidth: float, seed: int
) -> np.ndarray:
    """(S, nu) controls at `times` (S,): per actuator a sum of NUM_COMPONENTS sines up to
    `bandwidth` Hz with random phases, normalised to peak 1, times `amplitude` of half its range
    (`ranges` (nu, 2)) about the centre."""
    rng = np.random.default_rng(seed)
    frequencies = np.linspace(bandwidth / NUM_COMPONENTS, bandwidth, NUM_COMPONENTS)
    centre, half = ranges.mean(axis=1), (ranges[:, 1] - ranges[:, 0]) / 2
    phases = rng.uniform(0, 2 * np.pi, (len(ranges), NUM_COMPONENTS))
    waves = np.sin(
        2 * np.pi * frequencies[None, None, :] * times[:, None, None] + phases[None]
    ).sum(-1)
    waves /= np.maximum(np.abs(waves).max(axis=0), 1e-12)
    return np.clip(centre + amplitude * half * waves, ranges[:, 0], ranges[:, 1])


def excitation_episode(
    seed: int,
    model: "mujoco.MjModel",
    states: np.ndarray,
    sensors: np.ndarray,
    controls: np.ndarray,
    mocap_pos: np.ndarray | None = None,
    measurements: "Measurements | None" = None,
) -> "EpisodeArrays":
    """An open-loop episode in collect's layout (no plans): `states` (S, nq + nv) after each step,
    `sensors` (S, nsensordata), `controls` (S, nu) served during each step, `mocap_pos` (nmocap *
    3,) held throughout, and the measured sensors, their ages and the estimate where the plant
    reported measured sensors."""
    from judo.recording.dataset import EpisodeArrays

    steps = len(states)
    empty = np.zeros(0)
    plan = {
        "times": empty,
        "takes_effect": empty,
        "update_ms": empty,
        "best_reward": empty,
        "mean_reward": empty,
    }
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
        measured=None if measurements is None else measurements.measured,
        estimate=None if measurements is None else measurements.estimate,
        measured_sensors=() if measurements is None else measurements.names,
        measured_age=None if measurements is None else measurements.measured_age,
    )


def main(argv: list[str] | None = None) -> int:
    """Run `python -m judo excite` on `argv` (sys.argv[1:] when None); exits with status 2 on bad
    arguments."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(ExciteArgs, argv, "python -m judo excite", DESCRIPTION)
    try:
        args.validate()
        apply_config_file(args.config)
        return run(args)
    except JudoError as err:
        fail(str(err))


def run(args: ExciteArgs) -> int:
    """Excite the plant and write the log; 130 where a stop request (Ctrl-C, SIGTERM) ended it
    early, else 0."""
    from judo.core.configuration.model_overrides import parse_override_entries
    from judo.core.configuration.registry import make_task, set_model_overrides
    from judo.loop.system import MujocoSystem
    from judo.recording.dataset import DatasetFile
    from judo.system_choice import SIM, SystemOptions, build_system

    own = args.system is not None and args.system != SIM
    if own and args.plant_overrides:
        raise ConfigError(
            f"--plant-overrides set judo's simulated plant; --system {args.system} is its "
            "own plant: leave them out"
        )
    if args.plant_overrides:
        set_model_overrides(args.task, parse_override_entries(args.plant_overrides), plant=True)
    task = make_task(args.task)
    # a robot's limits are its MJCF's, the planning model's
    model = task.model if own else task.sim_model
    unlimited = [i for i in range(model.nu) if not model.actuator_ctrllimited[i]]
    if unlimited:
        name = model.actuator(unlimited[0]).name or f"#{unlimited[0]}"
        raise ConfigError(
            f"actuator {name} of {args.task} has no ctrlrange; excite stays within each "
            "actuator's limits"
        )
    system = build_system(SystemOptions(args.system), args.task) if own else None
    system = system if system is not None else MujocoSystem.from_task(task, args.seed)
    try:
        steps = excitation_steps(args, system)
        controls = multisine(
            model.actuator_ctrlrange,
            np.arange(steps) * system.timestep,
            args.amplitude,
            args.bandwidth,
            args.seed,
        )
        with progress_display(
            TextColumn(f"exciting {args.task}"), BarColumn(), MofNCompleteColumn()
        ) as progress:
            bar = progress.add_task("steps", total=steps)
            logged = drive(
                system,
                task,
                args.task,
                controls,
                paced=own,
                on_step=lambda done: progress.update(bar, completed=done),
            )
    finally:
        # a robot link: its last command acknowledged, its log finished
        close = getattr(system, "close", None)
        if callable(close):
            close()
    mocap = None
    if not own and model.nmocap:
        assert isinstance(system, MujocoSystem)
        mocap = system.task.data.mocap_pos.reshape(-1)
    episode = excitation_episode(
        args.seed,
        model,
        logged.states,
        logged.sensors,
        controls[: logged.steps],
        mocap,
        logged.measurements(task),
    )
    excitation = {
        "amplitude": args.amplitude,
        "bandwidth_hz": args.bandwidth,
        "duration": args.duration,
    }
    env_args = {"task": args.task, "excite": excitation, "plant_timestep": float(system.timestep)}
    if own:
        env_args["system"] = args.system
    DatasetFile(args.out, env_args).write_episode(episode)
    observed = (
        "its state" if logged.has_states else ("its measured sensors and the estimator's state")
    )
    where = f"through {type(system).__name__}" if own else "on judo's simulator"
    if logged.stopped:
        print(
            f"stopped after {logged.steps} of {steps} steps; {logged.halted}; wrote the "
            f"{logged.steps} steps "
            f"excited {where} ({observed}) to {args.out}"
        )
        return 130
    print(
        f"wrote {logged.steps} steps of excitation of {args.task} {where} ({observed}) to "
        f"{args.out}; {logged.halted}"
    )
    return 0


def excitation_steps(args: ExciteArgs, system: "System") -> int:
    """The steps of `system` --duration spans; a JudoError (one line) for a timestep that is not
    seconds > 0, a duration under one step or over MAX_STEPS, and a --bandwidth above the plant's
    Nyquist frequency."""
    timestep, name = getattr(system, "timestep", None), type(system).__name__
    require(
        isinstance(timestep, int | float)
        and not isinstance(timestep, bool)
        and 0 < timestep < math.inf,
        f"{name}.timestep must be the seconds one step() advances (a number > 0), got {timestep!r}",
    )
    assert isinstance(timestep, int | float)
    steps = round(args.duration / timestep)
    require(
        steps >= 1,
        f"--duration {args.duration} s is less than one step of {name} ({timestep:g} s); "
        "give at least that",
    )
    require(
        steps <= MAX_STEPS,
        f"--duration {args.duration:g} s is {steps} steps of {timestep:g} s; excite logs at "
        f"most {MAX_STEPS} steps "
        f"({MAX_STEPS * timestep:g} s at this timestep)",
    )
    nyquist = 0.5 / timestep
    require(
        args.bandwidth <= nyquist,
        f"--bandwidth must be at most the plant's Nyquist frequency, {nyquist:g} Hz (a step "
        f"of {timestep:g} s), "
        f"got {args.bandwidth:g}",
    )
    return steps
