"""A config file's user code: its errors keep the user's own lines, and its folder shadows no
installed package."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import judo

SRC = str(Path(judo.__file__).resolve().parents[1])


def write_module_and_config(directory: Path, module: str, source: str, **siblings: str) -> Path:
    (directory / f"{module}.py").write_text(textwrap.dedent(source))
    for name, text in siblings.items():
        (directory / f"{name}.py").write_text(textwrap.dedent(text))
    path = directory / "judo.toml"
    path.write_text(
        f'[custom_tasks.mine]\ntask = "{module}.MyTask"\nconfig = "{module}.MyConfig"\n'
    )
    return path


def unique(tmp_path: Path, stem: str) -> str:
    return f"{stem}_{tmp_path.name.replace('-', '_')}"


def test_a_syntax_error_names_the_file_the_entry_and_the_users_line(tmp_path):
    module = unique(tmp_path, "broken")
    path = write_module_and_config(tmp_path, module, "import judo\n\ndef reward(x:\n    return x\n")
    with pytest.raises(judo.ConfigFileError) as caught:
        judo.load_config(path)
    message = str(caught.value)
    assert message.startswith(
        f"{path}: [custom_tasks.mine]: importing module {module!r} (named by task = "
        f'"{module}.MyTask") failed:\n'
    )
    assert f'File "{tmp_path / module}.py", line 3' in message
    assert "def reward(x:" in message and "SyntaxError: " in message
    assert "judo/core" not in message and "importlib" not in message


def test_an_error_raised_while_importing_keeps_the_users_frames_only(tmp_path):
    module, helper = unique(tmp_path, "raises"), unique(tmp_path, "helper")
    path = write_module_and_config(
        tmp_path,
        module,
        f"import {helper}\n\nGAINS = {helper}.load_gains()\n",
        **{helper: "def load_gains():\n    raise RuntimeError('gains.yaml is missing')\n"},
    )
    with pytest.raises(judo.ConfigFileError) as caught:
        judo.load_config(path)
    message = str(caught.value)
    assert f"[custom_tasks.mine]: importing module {module!r}" in message
    assert f'File "{tmp_path / module}.py", line 3, in <module>' in message
    assert f'File "{tmp_path / helper}.py", line 2, in load_gains' in message
    assert message.endswith("RuntimeError: gains.yaml is missing")
    assert "judo/core" not in message and "importlib" not in message


def test_a_user_module_still_imports_its_sibling_files(tmp_path, tiny_model_path):
    module, helper = unique(tmp_path, "task_mod"), unique(tmp_path, "weights")
    source = f"""
        from dataclasses import dataclass
        import judo
        from {helper} import DEFAULT_WEIGHT

        @dataclass
        class MyConfig(judo.TaskConfig):
            weight: float = DEFAULT_WEIGHT

        class MyTask(judo.Task[MyConfig]):
            def __init__(self):
                super().__init__({str(tiny_model_path)!r})

            def reward(self, states, sensors, controls, config, system_metadata=None):
                return -config.weight * states[..., 0].sum(-1)
        """
    path = write_module_and_config(tmp_path, module, source, **{helper: "DEFAULT_WEIGHT = 3.0\n"})
    judo.load_config(path)
    assert judo.get_registered_tasks()["mine"][1]().weight == 3.0


def test_a_file_beside_the_config_does_not_shadow_an_installed_package(tmp_path):
    """websockets.py beside judo.toml, not named in it, must not replace the installed
    websockets."""
    (tmp_path / "websockets.py").write_text("raise SystemExit('the shadowing websockets.py ran')\n")
    (tmp_path / "judo.toml").write_text('task = "cartpole"\n')
    script = (
        "import judo, websockets; judo.load_config('judo.toml'); import websockets.sync; "
        "print(websockets.__file__)"
    )
    # safe path: no cwd entry from -c itself
    env = {**os.environ, "PYTHONPATH": SRC, "PYTHONSAFEPATH": "1"}
    result = subprocess.run(
        [sys.executable, "-c", script.replace("import judo, websockets;", "import judo;")],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert result.returncode == 0, result.stderr
    assert "site-packages" in result.stdout and "shadowing" not in result.stderr


def test_a_named_module_hidden_by_an_installed_one_is_explained(tmp_path):
    (tmp_path / "json.py").write_text("class MyTask: pass\nclass MyConfig: pass\n")
    path = tmp_path / "judo.toml"
    path.write_text('[custom_tasks.mine]\ntask = "json.MyTask"\nconfig = "json.MyConfig"\n')
    with pytest.raises(
        judo.ConfigFileError,
        match=r"names .*json.py, but 'json' is "
        r"also an installed module .*rename",
    ):
        judo.load_config(path)


@pytest.mark.parametrize(
    ("section", "line", "message"),
    [
        (
            "optimizer_config_overrides.cartpole.mppi",
            "sigma = nan",
            "MPPIConfig.sigma expects a finite number, got nan",
        ),
        (
            "controller_config_overrides.cartpole",
            "horizon = inf",
            "ControllerConfig.horizon expects a finite number",
        ),
        (
            "optimizer_config_overrides.cartpole.mppi",
            "num_rollouts = 10000000",
            "num_rollouts must be between 1 and 1048576, got 10000000",
        ),
        (
            "controller_config_overrides.cartpole",
            "control_freq = 0",
            "control_freq must be between 0.1 and 1000.0 Hz, got 0.0",
        ),
        (
            "controller_config_overrides.cartpole",
            "max_opt_iters = -1",
            "max_opt_iters must be between 1 and 100, got -1",
        ),
        (
            "task_config_overrides.cartpole",
            "w_centered = -inf",
            "CartpoleConfig.w_centered expects a finite number",
        ),
        (
            "optimizer_config_overrides.cartpole.cem",
            "num_nodes = 1e6",
            "num_nodes must be between 1 and 100",
        ),
    ],
)
def test_bad_numbers_in_a_file_are_refused_at_load_naming_the_file_entry_and_range(
    tmp_path, section, line, message
):
    path = tmp_path / "judo.toml"
    path.write_text(f"[{section}]\n{line}\n")
    with pytest.raises(judo.ConfigFileError) as caught:
        judo.load_config(path)
    assert str(caught.value).startswith(f"{path}: [{section}]: ")
    assert message in str(caught.value)
