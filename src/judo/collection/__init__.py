"""Datasets of closed-loop MPC episodes: `python -m judo collect` (docs/collect.md); judo.recording
writes them.

Nothing here is imported by `import judo`; h5py and ray (the `collect` extra) only where a command
needs them.
"""
