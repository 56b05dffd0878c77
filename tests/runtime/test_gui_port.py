"""The GUI depends on the command port (judo.runtime.command_port.AppPort), never on the App; the
App implements it."""

import ast
import inspect
import types
import typing
from pathlib import Path

import pytest

import judo.runtime.gui
from judo.runtime.app import App
from judo.runtime.command_port import AppPort, CommandPort

GUI_DIR = Path(judo.runtime.gui.__file__).parent
ALLOWED_RUNTIME_IMPORTS = {
    "judo.runtime.command_port",
    "judo.runtime.address",
    "judo.runtime.status",
    "judo.runtime.snapshots",
}
"""What the GUI may import from judo.runtime besides its own package: the port, the value types the
port's members return (the status line and figures, the published snapshots), each from the module
that defines it, and address checks for its server."""


def _imports(path: Path) -> set[str]:
    """Every module `path` imports, at any level (under TYPE_CHECKING too), as absolute dotted
    names; `from pkg import name` counts as both `pkg` and `pkg.name`, since `name` may be a
    module."""
    package = "judo.runtime.gui"
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{parent}.{base}" if base else parent
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return found


def _port_members() -> dict[str, object]:
    return {name: value for name, value in vars(AppPort).items() if not name.startswith("_")}


def test_the_gui_package_imports_nothing_from_the_app():
    files = sorted(GUI_DIR.glob("*.py"))
    assert len(files) >= 10, (
        f"expected the GUI package's modules in {GUI_DIR}, found {[f.name for f in files]}"
    )
    imported = {f.name: _imports(f) for f in files}
    from_app = {
        name: sorted(
            m for m in modules if m == "judo.runtime.app" or m.startswith("judo.runtime.app.")
        )
        for name, modules in imported.items()
    }
    assert {name: found for name, found in from_app.items() if found} == {}
    beyond_port = {
        name: sorted(
            m
            for m in modules
            if m.startswith("judo.runtime.")
            and not m.startswith("judo.runtime.gui")
            and not any(m == a or m.startswith(a + ".") for a in ALLOWED_RUNTIME_IMPORTS)
        )
        for name, modules in imported.items()
    }
    assert {name: found for name, found in beyond_port.items() if found} == {}
    assert "judo.runtime.command_port.AppPort" in imported["gui.py"]
    assert "judo.runtime.command_port.AppPort" in imported["controls.py"]


def test_the_gui_reads_and_calls_only_members_of_the_port():
    members = set(_port_members())
    used: dict[str, set[str]] = {}
    for path in sorted(GUI_DIR.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if not isinstance(node, ast.Attribute):
                continue
            owner = node.value
            is_app = (isinstance(owner, ast.Name) and owner.id == "app") or (
                isinstance(owner, ast.Attribute)
                and owner.attr == "app"
                and isinstance(owner.value, ast.Name)
                and owner.value.id == "self"
            )
            if is_app:
                used.setdefault(node.attr, set()).add(path.name)
    assert {"session", "commands", "report", "on_state"} <= set(used), (
        f"the GUI's uses of the app: {used}"
    )
    assert {name: files for name, files in used.items() if name not in members} == {}


def test_the_gui_calls_only_commands_of_the_command_port():
    members = {name for name in vars(CommandPort) if not name.startswith("_")}
    used: dict[str, set[str]] = {}
    for path in sorted(GUI_DIR.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute):
                if node.value.attr == "commands" and ast.unparse(node.value.value) in (
                    "app",
                    "self.app",
                ):
                    used.setdefault(node.attr, set()).add(path.name)
    assert {"update_config", "pause", "move_goal"} <= set(used), f"the GUI's commands: {used}"
    assert {name: files for name, files in used.items() if name not in members} == {}


def _parameters(fn: typing.Any) -> list[tuple[str, object, object]]:
    return [(p.name, p.kind, p.default) for p in inspect.signature(fn).parameters.values()]


@pytest.fixture
def unstarted_app():
    app = App("cartpole", "ps", gui=False, seed=0, num_workers=1)
    yield app
    app.session.close()


def test_the_app_implements_every_member_of_the_port(unstarted_app):
    app = unstarted_app
    assert isinstance(app, AppPort)
    members = _port_members()
    assert len(members) >= 15
    for name, declared in members.items():
        on_class = inspect.getattr_static(App, name, None)
        if isinstance(declared, property):
            assert isinstance(on_class, property) or (on_class is None and name in vars(app)), (
                f"AppPort.{name} is a read-only property; App has {on_class!r} for it"
            )
            wanted = typing.get_type_hints(declared.fget)["return"]
            # a nested port: its methods exist with the same signature
            if getattr(wanted, "_is_protocol", False):
                value = getattr(app, name)
                for method in (m for m in vars(wanted) if not m.startswith("_")):
                    got = getattr(value, method)
                    assert _parameters(got) == _parameters(getattr(wanted, method))[1:], (
                        f"App.{name}.{method}"
                    )
            else:
                kinds = (
                    typing.get_args(wanted) if isinstance(wanted, types.UnionType) else (wanted,)
                )
                kinds = tuple(
                    type(None) if kind is None else typing.get_origin(kind) or kind
                    for kind in kinds
                )
                assert isinstance(getattr(app, name), kinds), f"App.{name}"
        else:
            assert inspect.isfunction(on_class), (
                f"AppPort.{name} is a method; App has {on_class!r} for it"
            )
            assert _parameters(on_class) == _parameters(declared), (
                f"App.{name} takes other parameters than the port"
            )


def test_the_status_types_are_defined_once_and_neither_the_app_nor_the_port_re_exports_them():
    import judo.runtime.app as app_module
    import judo.runtime.command_port as command_port
    import judo.runtime.snapshots as snapshots
    import judo.runtime.status as status
    from judo.core.configuration import registry

    homes = {"Status": status, "SystemSnapshot": snapshots, "PlanSnapshot": snapshots}
    for name, home in homes.items():  # each imported from the module that defines it
        assert getattr(home, name).__module__ == home.__name__, name
    for name in (*homes, "ConfigKind", "CONFIG_KINDS"):
        assert name not in app_module.__all__ and name not in command_port.__all__, name
    assert (
        registry.CONFIG_KINDS
        == typing.get_args(registry.ConfigKind)
        == ("controller", "optimizer", "task")
    )
