"""Datasets of closed-loop MPC episodes: `python -m judo collect` and its HDF5 layout (docs/collect.md).

Nothing here is imported by `import judo`; h5py and ray (the `collect` extra) only where a command needs them.
"""
