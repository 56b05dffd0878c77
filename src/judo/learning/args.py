"""`DistillArgs`: the arguments of `python -m judo distill`, their bounds, and the TrainSettings
they ask for."""

import json
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Annotated, Any, Literal

import tyro

from judo.core.commandline.boundary import check_output_file
from judo.core.configuration.config import require, require_between
from judo.learning.settings import TrainSettings

ROUNDS_SUFFIX = "_rounds"
"""The teacher rounds' folder is OUT_rounds beside --out (OUT being --out's stem)."""


@dataclass
class DistillArgs(TrainSettings):
    """Arguments of `python -m judo distill`: the TrainSettings, and what to read, write and run
    around them."""

    datasets: Annotated[
        tuple[Path, ...], tyro.conf.Positional, tyro.conf.arg(metavar="DATA.h5")
    ] = field(kw_only=True)
    """Datasets written by python -m judo collect, all of one task."""
    out: Annotated[Path, tyro.conf.arg(metavar="POLICY.onnx")] = field(kw_only=True)
    """The ONNX file to write (its loss curves go beside it, as POLICY.losses.png)."""
    kind: Literal["action", "chunk"] = "action"
    """What the policy gives: the next action, or the plan's knots (a chunk)."""
    noise_scale: float = 1.0
    """The flow head's starting noise (1: samples from the learned distribution; 0: the
    deterministic sample)."""
    rounds: int = 0
    """Teacher rounds after the first training (DAgger): the policy drives, the MPC labels, retrain
    on all."""
    episodes_per_round: int = 10
    """New episodes each teacher round collects."""
    optimizer: Annotated[
        str | None, tyro.conf.arg(metavar="NAME", help_behavior_hint="(default: the dataset's)")
    ] = None
    """The MPC that labels in the teacher rounds."""
    proposals: int = 0
    """In the teacher rounds, the MPC that labels also samples K of its candidates from the policy
    (gpc's augmented controller); 0: the MPC alone labels."""
    eval_seeds: int = 3
    """Fresh seeds each round's table is measured on (the policy alone, and the MPC with its
    proposals)."""
    eval_first_seed: int = 10_000
    """The first of those seeds; keep it above every seed in the training data."""
    workers: Annotated[
        int | None, tyro.conf.arg(metavar="N", help_behavior_hint="(default: one per core)")
    ] = None
    """Episodes collected at once in the teacher rounds (the CPUs of a local Ray)."""
    address: Annotated[
        str | None, tyro.conf.arg(metavar="ADDRESS", help_behavior_hint="(default: a local Ray)")
    ] = None
    """A running Ray cluster for the teacher rounds' episodes: auto, or ray://HOST:10001."""
    overwrite: bool = False
    """Replace an --out file that exists (without it, distill refuses, unless it resumes the teacher
    rounds that wrote that file)."""

    def validate(self) -> None:
        """Raise a JudoError (one line) for an argument out of range or an --out that cannot be
        written."""
        require(
            len(self.datasets) > 0, "give at least one dataset written by python -m judo collect"
        )
        require(self.out.suffix == ".onnx", f"--out must name an .onnx file, got {str(self.out)!r}")
        require(
            all(0 < width <= 4096 for width in self.hidden),
            f"--hidden widths must be 1 to 4096, got {self.hidden}",
        )
        require_between("--epochs", self.epochs, 1, 100_000)
        require_between("--batch-size", self.batch_size, 1, 1_000_000)
        require(
            0 < self.learning_rate < 1,
            f"--learning-rate must be in (0, 1), got {self.learning_rate}",
        )
        require_between("--patience", self.patience, 1, 100_000)
        require_between("--flow-steps", self.flow_steps, 1, 100)
        require(
            0 <= self.noise_scale <= 10, f"--noise-scale must be 0 to 10, got {self.noise_scale}"
        )
        require_between("--rounds", self.rounds, 0, 100)
        require_between("--episodes-per-round", self.episodes_per_round, 1, 100_000)
        require_between("--proposals", self.proposals, 0, 100_000)
        require(
            self.proposals == 0 or self.rounds > 0,
            f"--proposals {self.proposals} samples candidates in the teacher rounds; give "
            "--rounds 1 or more with it",
        )
        require_between("--eval-seeds", self.eval_seeds, 0, 10_000)
        require(self.seed >= 0, f"--seed must be at least 0, got {self.seed}")
        require(
            0 < self.validation_fraction < 1,
            f"--validation-fraction must be in (0, 1), got {self.validation_fraction}",
        )
        check_output_file(
            "--out", self.out, (self.out.stem + ".losses.png", self.out.stem + ROUNDS_SUFFIX)
        )

    def rounds_folder(self) -> Path:
        """Where the teacher rounds' files go: OUT_rounds beside --out."""
        return self.out.with_name(self.out.stem + ROUNDS_SUFFIX)

    def run_record(self) -> dict[str, Any]:
        """What makes a teacher round's files: the training settings, the kind, the datasets and the
        teacher's flags, as JSON values. A resume must ask for the same (more --rounds is fine)."""
        record: dict[str, Any] = {
            item.name: getattr(self, item.name) for item in fields(TrainSettings)
        }
        record.update(
            kind=self.kind,
            noise_scale=self.noise_scale,
            datasets=[str(path.absolute()) for path in self.datasets],
            episodes_per_round=self.episodes_per_round,
            optimizer=self.optimizer,
            proposals=self.proposals,
        )
        return json.loads(json.dumps(record))  # tuples become lists, as they are read back

    def settings(self) -> TrainSettings:
        """The TrainSettings these arguments ask for."""
        return TrainSettings(
            **{item.name: getattr(self, item.name) for item in fields(TrainSettings)}
        )
