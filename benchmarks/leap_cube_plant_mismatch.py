"""leap_cube when the plant differs from the planning model: goals per minute and drops over seeds.

The controller plans on leap_cube.xml; the plant is leap_cube_plant.xml, the same scene with every
contact's friction overridden (see that file). Compare with `python -m judo evaluate --task
leap_cube
--optimizer cem`, where plant and planner share one model.

    PYTHONPATH=src python benchmarks/leap_cube_plant_mismatch.py --optimizer cem --seeds 3 --duration 60
"""  # noqa: E501

import argparse

import numpy as np

import judo
from judo.evaluation.episode import run_episode
from judo.loop.system import PLANT_STREAM, MujocoSystem
from judo.tasks.leap_cube import PLANT_MODEL_PATH, LeapCube


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--optimizer", default="cem", choices=sorted(judo.get_registered_optimizers())
    )
    parser.add_argument(
        "--seeds",
        type=int,
        default=3,
        help="episodes, with seeds first-seed to first-seed + seeds - 1",
    )
    parser.add_argument("--first-seed", type=int, default=0, help="the first episode's seed")
    parser.add_argument(
        "--duration", type=float, default=60.0, help="seconds of sim time per episode"
    )
    args = parser.parse_args()
    rows = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        controller = judo.make_controller("leap_cube", args.optimizer, seed=seed)
        plant = LeapCube(sim_model_path=PLANT_MODEL_PATH)
        plant.config = controller.task.config
        plant.rng = np.random.default_rng([seed, PLANT_STREAM])
        plant.reset()
        result = run_episode(controller, MujocoSystem(plant), args.duration, seed=seed)
        controller.close()
        rows.append(result.metrics)
        print(
            f"seed {seed}: " + ", ".join(f"{k}={v:.3g}" for k, v in result.metrics.items()),
            flush=True,
        )
    print("mean: " + ", ".join(f"{k}={np.mean([r[k] for r in rows]):.3g}" for k in rows[0]))


if __name__ == "__main__":
    main()
