"""viser's private internals: reached only from viser_internals.py, checked when the GUI starts, and
a viser that lacks one is refused with an error naming the installed viser, the tested range and
what is missing."""

import ast
import socket
import sys
from pathlib import Path

import pytest
import viser
import viser.infra
from packaging.specifiers import SpecifierSet
from viser import _messages

import judo.runtime.gui
from judo.core.errors import GuiStartError
from judo.runtime.gui import viser_internals
from judo.runtime.gui.server import start_server
from judo.runtime.gui.viser_internals import TESTED_VISER, VISER_HANDLER, check_viser, viser_version

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

GUI_DIR = Path(judo.runtime.gui.__file__).parent
PYPROJECT = Path(__file__).resolve().parents[2] / "pyproject.toml"


def start(port: int) -> viser.ViserServer:
    return start_server("127.0.0.1", port, token=None, share=False, label="judo test")


def listening(port: int) -> bool:
    with socket.socket() as sock:
        return sock.connect_ex(("127.0.0.1", port)) == 0


def test_the_installed_viser_is_in_the_tested_range_which_pyproject_pins_and_the_docs_name():
    assert viser_version() in SpecifierSet(TESTED_VISER)
    dependencies = tomllib.loads(PYPROJECT.read_text())["project"]["dependencies"]
    pins = [d for d in dependencies if d.startswith("viser")]
    assert pins == [f"viser{TESTED_VISER}"]
    assert f"`viser{TESTED_VISER}`" in (PYPROJECT.parent / "docs" / "gui.md").read_text()


def test_the_installed_viser_has_every_internal_the_gui_relies_on(port):
    check_viser()
    server = start(port)  # checks the running server's internals too
    try:
        assert listening(server.get_port())
    finally:
        server.stop()


MISSING = [
    (viser.ViserServer, "_run_garbage_collector", "viser.ViserServer._run_garbage_collector"),
    (viser.GuiApi, "_handle_gui_updates", "viser.GuiApi._handle_gui_updates"),
    (
        viser.infra.WebsockServer,
        "unregister_handler",
        "viser.infra.WebsockServer.unregister_handler",
    ),
    (viser.infra.WebsockServer, "register_handler", "viser.infra.WebsockServer.register_handler"),
    (
        viser.infra.WebsockClientConnection,
        "queue_message",
        "viser.infra.WebsockClientConnection.queue_message",
    ),
    (_messages, "GuiUpdateMessage", "viser._messages.GuiUpdateMessage"),
    (_messages, "ShareUrlRequest", "viser._messages.ShareUrlRequest"),
]


def assert_refused(error: pytest.ExceptionInfo[GuiStartError], missing: str) -> None:
    message = str(error.value)
    assert f"the installed viser {viser_version()}" in message
    assert f"it lacks {missing}" in message
    assert f"tested with viser{TESTED_VISER}" in message


@pytest.mark.parametrize(("owner", "name", "missing"), MISSING, ids=[m[2] for m in MISSING])
def test_a_viser_without_an_internal_is_refused_before_its_server_starts(
    monkeypatch, port, owner, name, missing
):
    # maybe a base class
    defined_on = next((c for c in getattr(owner, "__mro__", ()) if name in vars(c)), owner)
    monkeypatch.delattr(defined_on, name)
    with pytest.raises(GuiStartError) as error:
        start(port)
    assert_refused(error, missing)
    assert not listening(port)


def test_a_viser_whose_websocket_handler_is_named_otherwise_is_refused(monkeypatch, port):
    worker = viser.infra.WebsockServer._background_worker

    def background_worker(self, ready_sem):  # a release that serves from a function of another name
        return worker(self, ready_sem)

    monkeypatch.setattr(viser.infra.WebsockServer, "_background_worker", background_worker)
    with pytest.raises(GuiStartError) as error:
        start(port)
    assert_refused(error, f"the websocket handler {VISER_HANDLER}")
    assert not listening(port)


def test_a_viser_whose_client_handles_lack_their_connection_is_refused(monkeypatch, port):
    # a release whose ClientHandle keeps its connection under another name
    def init(self, conn, server):
        self.connection, self._viser_server, self.client_id = conn, server, conn.client_id

    monkeypatch.setattr(viser.ClientHandle, "__init__", init)
    with pytest.raises(GuiStartError) as error:
        start(port)
    assert_refused(error, "viser.ClientHandle._websock_connection")


def test_a_running_server_without_an_internal_is_refused_and_stopped(monkeypatch, port):
    init = viser.GuiApi.__init__

    # a release that keeps its widgets otherwise
    def without_widgets_by_uuid(self, *args, **kwargs):
        init(self, *args, **kwargs)
        del self._gui_input_handle_from_uuid

    monkeypatch.setattr(viser.GuiApi, "__init__", without_widgets_by_uuid)
    with pytest.raises(GuiStartError) as error:
        start(port)
    assert_refused(error, "viser.GuiApi._gui_input_handle_from_uuid")
    assert not listening(port)  # the server that started was stopped


def test_a_gui_start_refused_for_its_viser_leaves_the_next_start_free(monkeypatch, port):
    monkeypatch.delattr(viser.ViserServer, "_run_garbage_collector")
    with pytest.raises(GuiStartError):
        start(port)
    monkeypatch.undo()
    server = start(port)
    server.stop()


def _private_uses(path: Path) -> list[str]:
    """Where `path` reaches a private name of another object (`x._name`, `getattr(x, "_name")`) or
    imports a private viser module: `line: code`."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        private = None
        if isinstance(node, ast.Attribute) and not (
            isinstance(node.value, ast.Name) and node.value.id == "self"
        ):
            private = node.attr
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id.endswith("attr")
        ):
            name = node.args[1] if len(node.args) > 1 else None
            private = (
                name.value
                if isinstance(name, ast.Constant) and isinstance(name.value, str)
                else None
            )
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("viser"):
            modules = [node.module or "", *(f"{node.module}.{a.name}" for a in node.names)]
            private = next((m.rsplit(".", 1)[1] for m in modules if "._" in m), None)
        elif isinstance(node, ast.Import):
            private = next(
                (a.name.rsplit(".", 1)[1] for a in node.names if a.name.startswith("viser._")), None
            )
        if private and private.startswith("_") and not private.startswith("__"):
            found.append(f"{node.lineno}: {ast.unparse(node)}")
    return found


def test_only_viser_internals_reaches_into_private_names():
    files = sorted(GUI_DIR.glob("*.py"))
    assert len(files) >= 10, f"expected the GUI package's modules in {GUI_DIR}"
    uses = {path.name: _private_uses(path) for path in files}
    assert uses.pop("viser_internals.py"), "the rule finds nothing even where the privates are"
    assert {name: found for name, found in uses.items() if found} == {}
    assert viser_internals.__doc__ and "public API lacks" in viser_internals.__doc__
