"""A user's cart-pole robot whose pole is heavier than its MJCF says (examples/11_sysid,
docs/sysid.md).

The task plans with judo's cartpole.xml (pole 0.1 kg) while its plant, `sim_model_path`, is
heavy_pole.xml (0.3 kg): the robot a user meets on hardware. `python -m judo sysid` finds the pole's
mass from a logged run.
"""

from pathlib import Path

from judo.tasks.cartpole import MODEL_PATH, Cartpole, CartpoleConfig

HEAVY_POLE_PATH = Path(__file__).with_name("heavy_pole.xml")


class HeavyCartpole(Cartpole):
    """judo's cart-pole task on a plant with a pole three times as heavy."""

    def __init__(self) -> None:
        super().__init__(MODEL_PATH, sim_model_path=HEAVY_POLE_PATH)


HeavyCartpoleConfig = CartpoleConfig
