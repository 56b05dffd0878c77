"""The collect dataset without Ray: its layout against docs/collect.md, the doc's loader, refusals,
the extra."""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from judo.collection.collect import main as collect_main
from judo.collection.episode import collect_episode
from judo.core.configuration.registry import lookup_optimizer, lookup_task, make_config
from judo.evaluation.seeded import EpisodeSpec
from judo.recording.dataset import DatasetError, DatasetFile

h5py = pytest.importorskip("h5py")

DOC = (Path(__file__).resolve().parents[2] / "docs" / "collect.md").read_text()
ENV_ARGS = {"task": "leap_cube", "optimizer": "ps", "env_kwargs": {"optimizer": {"sigma": 0.3}}}


def documented_layout() -> dict[str, tuple[str, str]]:
    """{path under data/demo_<seed>: (shape, dtype)} from the doc's table."""
    rows = re.findall(r"^\| `data/demo_<seed>/([^`]+)` \| (\([^)]*\)) \| (\w+) \|", DOC, flags=re.M)
    return {path: (shape, dtype) for path, shape, dtype in rows}


@pytest.fixture(scope="module")
def leap_cube_file(tmp_path_factory):
    """A file with seeds 0 and 1 of a 0.2 s leap_cube x ps episode (leap_cube has a mocap goal)."""
    path = tmp_path_factory.mktemp("collect") / "leap_cube.h5"
    dataset = DatasetFile(path, ENV_ARGS)
    for seed in (0, 1):
        outcome = collect_episode(EpisodeSpec("leap_cube", "ps", 0.2), seed)
        assert outcome.failure is None
        dataset.write_episode(outcome.episode)
    return path


def test_the_layout_and_dtypes_are_the_documented_ones(leap_cube_file):
    layout = documented_layout()
    assert len(layout) == 22
    # test_collect_sensing
    sensed = {"obs/measured", "obs/measured_age", "obs/estimate_qpos", "obs/estimate_qvel"}
    sensed |= {"plan/traces"}  # test_collect_sensing.py
    # collect --policy: test_collect_policy.py
    sensed |= {"mpc_actions", "policy/knots", "policy/inference_ms"}
    # a task's recorded_metadata (leap_cube has none): test_collect_metadata.py
    sensed |= {"obs/metadata/<key>"}
    model = lookup_task("leap_cube")[0]().sim_model
    sizes = {
        "nq": model.nq, "nv": model.nv, "nu": model.nu, "nsensordata": model.nsensordata,
        "3 * nmocap": 3 * model.nmocap, "num_nodes": make_config(lookup_optimizer("ps")[1], "leap_cube").num_nodes,  # noqa: E501
    }  # fmt: skip
    with h5py.File(leap_cube_file, "r") as file:
        data = file["data"]
        assert sorted(data) == ["demo_0", "demo_1"]
        # the mark of a file judo wrote
        assert json.loads(data.attrs["env_args"]) == {**ENV_ARGS, "type": "judo"}
        assert data.attrs["total"] == 2 * 20
        demo = data["demo_1"]
        steps, updates = demo.attrs["num_samples"], len(demo["plan/times"])
        assert (steps, updates, demo.attrs["seed"]) == (20, 4, 1)
        for path in sensed | {"obs/metadata"}:
            assert path not in demo, path  # a full-state MPC episode without --traces
        for path, (shape, dtype) in layout.items():
            if path in sensed:
                continue
            dims = [d.strip() for d in shape.strip("(,)").split(",") if d.strip()]
            expected = tuple({"S": steps, "U": updates}.get(d, sizes.get(d)) for d in dims)
            assert demo[path].shape == expected, path
            assert demo[path].dtype == np.dtype(dtype), path
        assert demo["dones"][:].tolist() == [0] * 19 + [1]
        assert set(json.loads(demo.attrs["metrics"])) == {
            "goals_reached",
            "goals_per_minute",
            "drops",
            "mean_reward",
        }
        assert demo.attrs["success"] in (True, False)
        plan = demo["plan"]
        assert np.all(np.diff(plan["times"][:]) > 0) and np.array_equal(
            plan["takes_effect"][:], plan["times"][:]
        )
        assert np.all(plan["best_reward"][:] >= plan["mean_reward"][:])


def test_the_docs_loader_turns_a_file_into_observation_and_action_arrays(
    leap_cube_file, tmp_path, monkeypatch
):
    marker = "<!-- tests/collection/test_collect_dataset.py runs this loader on a real file -->"
    loader = re.search(re.escape(marker) + r"\n```python\n(.*?)\n```", DOC, flags=re.S).group(1)
    code_lines = [
        line for line in loader.splitlines() if line.strip() and not line.strip().startswith('"""')
    ]
    assert len(code_lines) <= 15
    (tmp_path / "cartpole.h5").symlink_to(leap_cube_file)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(loader, "docs/collect.md", "exec"), namespace)
    observations, actions = namespace["observations"], namespace["actions"]
    model = lookup_task("leap_cube")[0]().sim_model
    assert observations.shape == (40, model.nq + model.nv) and actions.shape == (40, model.nu)
    with h5py.File(leap_cube_file, "r") as file:
        assert np.array_equal(actions[20:], file["data/demo_1/actions"][:])
        assert np.array_equal(observations[:20, : model.nq], file["data/demo_0/obs/qpos"][:])


def test_a_file_of_other_settings_is_refused_naming_what_differs(leap_cube_file):
    other = {**ENV_ARGS, "env_kwargs": {"optimizer": {"sigma": 0.5}}, "judo_version": "9"}
    with pytest.raises(
        DatasetError,
        match=r"env_kwargs\.optimizer\.sigma: "
        r"file has 0\.3, this run 0\.5\);",
    ):
        DatasetFile(leap_cube_file, other)
    assert DatasetFile(leap_cube_file, {**ENV_ARGS, "judo_version": "9"}).finished_seeds() == {0, 1}


def test_without_the_extra_collect_names_it(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(SystemExit) as exit_info:
        collect_main(["--task", "cartpole", "--optimizer", "ps", "--out", str(tmp_path / "x.h5")])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.strip() == (
        "error: python -m judo collect needs the optional extra judo-mpc[collect], which is "
        "not installed "
        "(no module 'h5py'); install it with: pip install -e \".[collect]\" (from a checkout) or "
        'pip install "judo-mpc[collect]"'
    )


def test_importing_judo_and_the_collect_command_imports_neither_h5py_nor_ray():
    code = (
        "import sys, judo, judo.collection.collect, judo.collection.run; print(sorted({'h5py', "
        "'ray'} & set(sys.modules)))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == "[]"


def test_a_failed_episode_is_recorded_with_its_reason_and_run_again_on_resume(tmp_path):
    from judo.collection.run import Tally, write_outcome
    from judo.core.configuration.registry import register_task
    from tests.conftest import TINY_CARTPOLE_XML, UprightConfig, UprightTask

    model_path = tmp_path / "tiny.xml"
    model_path.write_text(TINY_CARTPOLE_XML)

    class BrokenMetrics(UprightTask):
        def __init__(self):
            super().__init__(model_path)

        def metrics(self, log):
            raise ValueError("no metrics today")

    register_task("broken_metrics", BrokenMetrics, UprightConfig)
    outcome = collect_episode(EpisodeSpec("broken_metrics", "ps", 0.05), 3)
    assert outcome.episode is None and outcome.failure.startswith("ValueError: no metrics today (")
    dataset, tally = DatasetFile(tmp_path / "broken.h5", {"task": "broken_metrics"}), Tally()
    write_outcome(dataset, outcome, False, tally, "broken_metrics")
    assert (tally.done, tally.failed, tally.kept) == (1, 1, 0)
    with h5py.File(tmp_path / "broken.h5", "r") as file:
        assert dict(file["judo/failed"].attrs) == {"3": outcome.failure}
    assert dataset.finished_seeds() == set()  # a resumed run tries seed 3 again


def test_success_only_for_a_task_without_a_rule_says_what_to_add(tmp_path):
    from judo.collection.run import NoSuccessRuleError, Tally, write_outcome

    outcome = collect_episode(EpisodeSpec("leap_cube", "ps", 0.05), 0)
    outcome.episode.success, outcome.episode.metrics = None, {"distance": 0.1}
    dataset = DatasetFile(tmp_path / "rule.h5", ENV_ARGS)
    with pytest.raises(NoSuccessRuleError) as error:
        write_outcome(dataset, outcome, True, Tally(), "my_task")
    assert str(error.value) == (
        "--success-only: task 'my_task' has no success rule for its metrics ['distance']; "
        "give the task a "
        "`success(self, metrics) -> bool` method, or report a 'success' metric"
    )
    assert dataset.counts() == {"kept": 0, "dropped": 0, "failed": 0, "total": 0}
