"""Contracts and machinery shared by every task and optimizer; the public names are re-exported by `judo`."""
