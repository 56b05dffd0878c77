"""judo's version, in one place: the package's `judo.__version__` and what collect records in its
files."""

__version__ = "0.1.0"
