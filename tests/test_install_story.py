"""The install story: the distribution is judo-mpc (the index's `judo` is another project), so no
doc, example or error message tells a user to install `judo[...]`; mujoco is bounded to what CI
runs; and the built-in tasks that run ONNX policies name themselves when onnxruntime is missing."""

import re
import sys
from pathlib import Path

import pytest

from judo.core.errors import MissingExtraError

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
SCANNED = [ROOT / "README.md", *(ROOT / "docs").glob("*.md")] + [
    path
    for folder in ("src", "examples", "benchmarks")
    for path in (ROOT / folder).rglob("*")
    if path.suffix in (".py", ".md", ".ipynb")
]
WRONG_INSTALL = re.compile(r"""pip install\s+\\?["']?judo\[|\\?["']judo\[""")


def test_no_doc_example_or_error_installs_the_other_judo():
    offenders = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
        for path in SCANNED
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if WRONG_INSTALL.search(line)
    ]
    assert offenders == []
    assert WRONG_INSTALL.search("""pip install "judo[tune]\"""") and WRONG_INSTALL.search(
        "pip install 'judo[warp]'"
    )
    assert not WRONG_INSTALL.search('''pip install -e ".[tune]" or pip install "judo-mpc[tune]"''')


def test_the_distribution_is_judo_mpc_with_mujoco_bounded():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["name"] == "judo-mpc"
    extras = project["optional-dependencies"].values()
    self_references = [dep for extra in extras for dep in extra if dep.startswith("judo")]
    assert self_references and all(dep.startswith("judo-mpc[") for dep in self_references)
    (mujoco,) = [dep for dep in project["dependencies"] if dep.startswith("mujoco")]
    assert mujoco == "mujoco>=4.0,<4.1"
    # the built-in tasks need them
    assert {"onnxruntime>=1.17", "onnx>=1.15"} <= set(project["dependencies"])


@pytest.mark.parametrize(
    ("task", "missing"),
    [("quadruped_navigate", "onnxruntime"), ("cartpole_pd", "onnx")],
    ids=["quadruped", "pd"],
)
def test_a_task_with_a_shipped_policy_names_itself_and_the_extra_when_onnx_is_missing(
    task, missing, monkeypatch
):
    from judo.core.configuration.registry import lookup_task

    task_cls, _ = lookup_task(task)
    # makes the import raise ImportError, as without the package
    monkeypatch.setitem(sys.modules, missing, None)
    with pytest.raises(MissingExtraError) as caught:
        task_cls()
    message = str(caught.value)
    assert message.startswith(f"task {task} (") and f"(no module {missing!r})" in message
    assert (
        'pip install -e ".[policy]" (from a checkout) or pip install "judo-mpc[policy]"' in message
    )
    assert "--policy" not in message
