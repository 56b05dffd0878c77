"""What judo refuses to read or write, on real HDF5 files written here: collect never writes into
another program's file (and leaves it byte for byte as it was), and replay checks a file's keys,
shapes and finiteness as it loads it, naming what is missing or wrong in one line."""

import json

import numpy as np
import pytest

from judo.recording.dataset import DatasetError, DatasetFile
from judo.runtime.gui.replay import Replay
from judo.runtime.gui.replay_episodes import read_demos

h5py = pytest.importorskip("h5py")

ENV_ARGS = {"type": "judo", "task": "cartpole", "optimizer": "ps", "plant_timestep": 0.01}


def write_replay_file(
    path, qpos, env_args=None, mocap_pos=None, plan_times=(0.0, 0.02), drop=()
) -> None:
    """A cartpole file in collect's layout (the parts replay reads), one demo of seed 0 holding
    `qpos`, without the datasets or attributes named in `drop`."""
    with h5py.File(path, "w") as file:
        file.create_group("data").attrs["env_args"] = json.dumps(
            ENV_ARGS if env_args is None else env_args
        )
        demo = file.create_group("data/demo_0")
        arrays = {
            "obs/qpos": qpos,
            "plan/times": np.asarray(plan_times),
            "obs/mocap_pos": mocap_pos,
        }
        for key, value in arrays.items():
            if value is not None and key not in drop:
                demo[key] = value
        demo.attrs.update(
            {
                k: v
                for k, v in {"seed": 0, "metrics": "{}", "success": False}.items()
                if k not in drop
            }
        )


def replay_error(path) -> str:
    """The DatasetError a Replay of `path` raises (nothing is served: the file is refused as it
    loads)."""
    with pytest.raises(DatasetError) as err:
        Replay(path)
    return str(err.value)


def test_collect_refuses_another_programs_file_and_leaves_it_as_it_was(tmp_path):
    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as file:
        file["images"] = np.arange(6.0).reshape(2, 3)
        file.attrs["owner"] = "a lab"
    before = path.read_bytes()
    with pytest.raises(DatasetError) as err:
        DatasetFile(path, ENV_ARGS)
    assert str(err.value) == (
        f"{path} is an HDF5 file judo did not write (it holds images and no judo env_args); "
        "judo writes only into "
        "its own datasets: give another file"
    )
    assert path.read_bytes() == before


def test_a_robomimic_file_of_another_program_is_refused_too(tmp_path):
    path = tmp_path / "robomimic.h5"
    # robomimic's own layout: its env_args "type" is an environment number
    with h5py.File(path, "w") as file:
        file.create_group("data/demo_0")
        file["data"].attrs["env_args"] = json.dumps({"env_name": "Lift", "type": 1})
    with pytest.raises(
        DatasetError, match="robomimic.h5 is an HDF5 file judo did not write .it holds data and no"
    ):
        DatasetFile(path, ENV_ARGS)


def test_an_empty_hdf5_file_and_judos_own_are_written_and_marked_as_judos(tmp_path):
    path = tmp_path / "empty.h5"
    h5py.File(path, "w").close()
    DatasetFile(path, {"task": "cartpole"})
    DatasetFile(path, {"task": "cartpole"})  # reopened: judo's own, the same run
    with h5py.File(path, "r") as file:
        assert json.loads(file["data"].attrs["env_args"]) == {"task": "cartpole", "type": "judo"}


def test_a_sound_file_loads(tmp_path):
    path = tmp_path / "good.h5"
    write_replay_file(path, np.zeros((5, 2)))
    replay = Replay(path)
    assert replay.demo.seed == 0 and replay.demo.qpos.shape == (5, 2) and replay.token is None
    np.testing.assert_allclose(replay.demo.times, 0.01 * np.arange(1, 6))


def test_a_nan_or_inf_row_is_refused_naming_the_key_and_the_row(tmp_path):
    qpos = np.zeros((5, 2))
    qpos[3, 1] = np.nan
    qpos[4, 0] = np.inf
    write_replay_file(tmp_path / "nan.h5", qpos)
    assert replay_error(tmp_path / "nan.h5") == (
        f"{tmp_path / 'nan.h5'}: data/demo_0/obs/qpos holds non-finite values (NaN or inf) "
        "in 2 of its 5 rows, "
        "the first row 3"
    )
    write_replay_file(tmp_path / "times.h5", np.zeros((5, 2)), plan_times=(0.0, np.nan))
    assert replay_error(tmp_path / "times.h5").endswith("data/demo_0/plan/times holds "
                                                        "non-finite values (NaN or inf) "
                                                        "in 1 of its 2 rows, the first row 1")  # fmt: skip  # noqa: E501


def test_arrays_of_the_wrong_shape_are_refused_naming_the_shape_expected(tmp_path):
    write_replay_file(tmp_path / "narrow.h5", np.zeros((5, 1)))
    assert replay_error(tmp_path / "narrow.h5") == (
        f"{tmp_path / 'narrow.h5'}: data/demo_0/obs/qpos must have shape (S, 2) for "
        "cartpole's nq = 2, got (5, 1)"
    )
    write_replay_file(tmp_path / "flat.h5", np.zeros(5))
    assert replay_error(tmp_path / "flat.h5").endswith(
        "obs/qpos must have shape (S, 2) for cartpole's nq = 2, got (5,)"
    )
    write_replay_file(tmp_path / "empty.h5", np.zeros((0, 2)))
    assert replay_error(tmp_path / "empty.h5").endswith(
        "obs/qpos must have shape (S, 2) for cartpole's nq = 2, got (0, 2)"
    )
    write_replay_file(tmp_path / "traces.h5", np.zeros((5, 2)))
    with h5py.File(tmp_path / "traces.h5", "a") as file:
        # one plan's traces for the file's two plans
        file["data/demo_0/plan/traces"] = np.zeros((1, 2, 3, 1, 3))
    with pytest.raises(
        DatasetError,
        match=r"data/demo_0/plan/traces must have shape "
        r"\(2, \.\.\., 3\), got \(1, 2, 3, 1, 3\)$",
    ):
        read_demos(tmp_path / "traces.h5")
    # cartpole has no mocap
    write_replay_file(tmp_path / "mocap.h5", np.zeros((5, 2)), mocap_pos=np.zeros((5, 3)))
    assert replay_error(tmp_path / "mocap.h5").endswith(
        "data/demo_0/obs/mocap_pos must have shape (S, 0) for cartpole's 0 mocap bodies, got (5, 3)"
    )


@pytest.mark.parametrize(
    ("drop", "env_args", "missing"),
    [
        ((), {**ENV_ARGS, "plant_timestep": None}, "data's env_args has no entry 'plant_timestep'"),
        ((), {"type": "judo", "plant_timestep": 0.01}, "data's env_args has no entry 'task'"),
        ((), {**ENV_ARGS, "optimizer": None}, "data's env_args has no entry 'optimizer'"),
        (("obs/qpos",), ENV_ARGS, "data/demo_0 has no dataset 'obs/qpos'"),
        (("plan/times",), ENV_ARGS, "data/demo_0 has no dataset 'plan/times'"),
        (("seed",), ENV_ARGS, "data/demo_0 has no attribute 'seed'"),
        (("metrics",), ENV_ARGS, "data/demo_0 has no attribute 'metrics'"),
    ],
)
def test_a_missing_key_is_named_in_plain_words(tmp_path, drop, env_args, missing):
    path = tmp_path / "missing.h5"
    env_args = {key: value for key, value in env_args.items() if value is not None}
    write_replay_file(path, np.zeros((5, 2)), env_args=env_args, drop=drop)
    with pytest.raises(DatasetError) as err:
        read_demos(path)
    assert str(err.value) == f"{path} is not a file of `python -m judo collect`: {missing}"


def test_a_file_without_a_data_group_or_with_a_bad_timestep_is_named(tmp_path):
    path = tmp_path / "bare.h5"
    with h5py.File(path, "w") as file:
        file["images"] = np.zeros(3)
    with pytest.raises(
        DatasetError,
        match=r"bare.h5 is not a file of `python -m judo "
        r"collect`: the file has no group 'data'$",
    ):
        read_demos(path)
    write_replay_file(path, np.zeros((5, 2)), env_args={**ENV_ARGS, "plant_timestep": 0.0})
    with pytest.raises(
        DatasetError, match="entry 'plant_timestep' must be above 0 and at most 1 s, got 0.0$"
    ):
        read_demos(path)
