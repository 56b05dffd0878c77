"""The public API: every exported name exists and is documented in docs/api.md."""

import re
from pathlib import Path

import judo

API_DOC = (Path(__file__).resolve().parents[1] / "docs" / "api.md").read_text()


def test_every_public_name_exists_and_is_documented():
    documented = set(re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)", API_DOC))
    missing = [name for name in judo.__all__ if name not in documented]
    assert not missing, f"add these to docs/api.md: {missing}"
    assert all(hasattr(judo, name) for name in judo.__all__)
