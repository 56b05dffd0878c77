"""Learning policies from judo's own MPC: `python -m judo distill` (docs/learning.md).

    collect (MPC episodes, HDF5)  ->  training pairs (pairs.py)  ->  an MLP trained with JAX on the CPU
    (networks.py, training.py)  ->  an ONNX file with its own metadata (export.py)  ->  OnnxPolicy
    teacher rounds (rounds.py): the policy drives, the MPC labels the states it visits, retrain on everything

This package sits above collection: it reads datasets and runs collect and evaluate; nothing below
it imports it. JAX and optax come with the judo-mpc[learn] extra and are imported only inside the
functions that train.
"""  # noqa: E501
