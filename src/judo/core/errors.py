"""Errors raised by judo. Every message says what was expected, what was got, and the valid
choices."""

from collections.abc import Iterable


class JudoError(Exception):
    """Root of every error judo raises on purpose; catch this to handle any of them."""


class UnknownNameError(JudoError, KeyError):
    """A task, optimizer, field, sensor or joint name that does not exist."""

    def __init__(self, kind: str, name: str, valid: Iterable[str]) -> None:
        self.kind, self.name, self.valid = kind, name, sorted(valid)
        choices = ", ".join(self.valid) if self.valid else "(none)"
        # never a 50 MB name whole
        asked = repr(name) if len(repr(name)) <= 200 else f"{repr(name)[:200]}..."
        super().__init__(f"unknown {kind} {asked}; valid {kind}s are: {choices}")

    def __str__(self) -> str:  # KeyError would otherwise wrap the message in quotes
        return str(self.args[0])


class ConfigError(JudoError, ValueError):
    """A config value that is out of range, of the wrong type, or inconsistent with another."""


class ModelLoadError(JudoError):
    """A MuJoCo model that could not be read or compiled."""


class MissingExtraError(JudoError, ImportError):
    """A feature that needs an optional extra that is not installed. The distribution is `judo-mpc`
    (the index's `judo` is another project), so the message names `pip install -e ".[EXTRA]"` from a
    checkout and `pip install "judo-mpc[EXTRA]"` from the index."""

    def __init__(self, feature: str, extra: str, missing: str) -> None:
        self.feature, self.extra, self.missing = feature, extra, missing
        super().__init__(
            f"{feature} needs the optional extra judo-mpc[{extra}], which is not installed "
            f"(no module {missing!r}); "
            f'install it with: pip install -e ".[{extra}]" (from a checkout) or pip install '
            f'"judo-mpc[{extra}]"'
        )


def import_extra(module: str, feature: str, extra: str):  # returns the module
    """Import `module` from an optional extra, or raise MissingExtraError naming the extra to
    install."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as err:
        missing = err.name or module
        raise MissingExtraError(feature, extra, missing) from err


class GuiStartError(JudoError):
    """The GUI server could not start (an address that is not this machine's, a port out of range,
    ...)."""


class NonFiniteRewardError(JudoError):
    """Every rollout of a cycle scored NaN or -inf (or diverged), so there is nothing to learn from;
    the plan is kept, and the closed loop counts a failed update."""


class NonFiniteKnotsError(JudoError):
    """The optimizer sampled or returned NaN or infinite knots; its search was restarted and the
    plan is kept."""


class ReadingTimeError(JudoError):
    """A reading's time went backwards (a System's clock must never run back); the reading is
    refused."""
