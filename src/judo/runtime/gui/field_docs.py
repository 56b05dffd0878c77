"""The docstring line under each dataclass field, for the GUI's hover hints (shared with the CLIs, in core)."""

from judo.core.configuration.field_docs import field_docs

__all__ = ["field_docs"]
