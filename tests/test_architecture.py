"""The shape of src/judo, checked from the source: no import circles, and small files.

An import circle is counted from every `import` and `from ... import` statement in src/judo, at
module level or inside a function or an `if TYPE_CHECKING:` block: modules are nodes, an import of a
judo module is an edge to it, and each strongly connected component of more than one module (or a
module importing itself) is one circle. A module named by a string for importlib is an edge too
(`named_modules`): "judo.x.y:attr" in a plugin table anywhere (__main__'s commands, a System by
name), and "judo.x.y" or "judo.x.y.Attr" in a module that calls importlib.import_module (the rollout
factory's `BACKEND_CLASSES`), since the module that loads it depends on it as surely as an import
would.

The same imports, gathered by package (judo.core, judo.runtime, ..., and a module directly in judo
such as judo.ray_cluster as its own), must form no circle either, and follow PACKAGE_ORDER: a
package imports only those below it, inside functions too. No module imports the root package.
"""

import ast
import os
import re
import subprocess
import sys
from collections.abc import Set
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
PACKAGE = "judo"

MAX_LINES = 400
"""Most lines in any file in src/judo, but those below."""

LONGER_FILES = {}
"""Files allowed more lines, and why (none: every file is split by idea below MAX_LINES)."""


def module_name(path: Path, root: Path) -> str:
    """`judo/core/rollouts/rollout.py` -> "judo.core.rollouts.rollout"; `judo/core/__init__.py` ->
    "judo.core"."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imported_modules(path: Path, module: str, modules: set[str]) -> set[str]:
    """The modules among `modules` that the file at `path` (module `module`) imports, anywhere in
    it.

    `import a.b.c` and `from a.b import c` name the module a.b.c when it is one of `modules`, else
    the longest prefix that is (`from judo.core.rollouts.rollout import RolloutPool` ->
    judo.core.rollouts.rollout). Relative imports are resolved against `module`'s package."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: set[str] = set()

    def longest_known(dotted: str) -> str | None:
        while dotted and dotted not in modules:
            dotted = dotted.rpartition(".")[0]
        return dotted or None

    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join([*anchor, *([base] if base else [])])
            targets = [
                f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                for alias in node.names
            ]
        else:
            continue
        found.update(target for name in targets if (target := longest_known(name)))
    return found | named_modules(path, module, modules)


PLUGIN_PATH = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)+(:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*)?")
"""A dotted name, optionally followed by ":attr": how a plugin table or an importlib call names a
module."""


def calls_import_module(tree: ast.AST) -> bool:
    """Whether the code calls `importlib.import_module` (or an `import_module` imported from
    importlib)."""
    return any(
        isinstance(node, ast.Call)
        and (
            getattr(node.func, "attr", None) == "import_module"
            or getattr(node.func, "id", None) == "import_module"
        )
        for node in ast.walk(tree)
    )


def named_modules(path: Path, module: str, modules: set[str]) -> set[str]:
    """The modules among `modules` that string constants in the file at `path` (module `module`)
    name for importlib.

    "pkg.mod:attr" counts wherever it stands (a plugin table such as __main__'s commands or
    system_choice's systems, handed to a loader elsewhere); in a file that calls
    importlib.import_module, so do "pkg.mod" and "pkg.mod.attr" (core/rollouts' backend table names
    "judo.core.rollouts.rollout.RolloutPool"). The root package, the module itself, docstrings and
    other strings (a logger's "judo.app", an f-string's pieces) name no module."""
    tree = ast.parse(path.read_text(), str(path))
    docstrings = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
    loads = calls_import_module(tree)
    found: set[str] = set()
    for node in ast.walk(tree):
        if (
            not (isinstance(node, ast.Constant) and isinstance(node.value, str))
            or id(node) in docstrings
        ):
            continue
        if not PLUGIN_PATH.fullmatch(node.value):
            continue
        dotted, colon, _ = node.value.partition(":")
        if colon:
            target = dotted
        elif loads:
            target = dotted if dotted in modules else dotted.rpartition(".")[0]
        else:
            continue
        if target in modules and "." in target:
            found.add(target)
    return found - {module}


def import_graph(root: Path = SRC, package: str = PACKAGE) -> dict[str, set[str]]:
    """Each module of `package` (under `root`) -> the modules of the package it imports."""
    paths = {module_name(path, root): path for path in sorted((root / package).rglob("*.py"))}
    modules = set(paths)
    return {module: imported_modules(path, module, modules) for module, path in paths.items()}


def strongly_connected_components(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm, iterative: every strongly connected component of `graph`, each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, successors = work[-1]
            for successor in successors:
                if successor not in index:
                    index[successor] = low[successor] = len(index)
                    stack.append(successor)
                    on_stack.add(successor)
                    work.append((successor, iter(sorted(graph[successor]))))
                    break
                if successor in on_stack:
                    low[node] = min(low[node], index[successor])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    components.append(sorted(component))
    return components


def import_cycles(root: Path = SRC, package: str = PACKAGE) -> list[list[str]]:
    """Every import circle in `package`: each strongly connected component of the import graph with
    more than one module, or a module that imports itself; each a sorted list of module names."""
    graph = import_graph(root, package)
    return sorted(
        component
        for component in strongly_connected_components(graph)
        if len(component) > 1 or component[0] in graph[component[0]]
    )


def explain(cycles: list[list[str]], graph: dict[str, set[str]]) -> str:
    """Each circle with the imports that close it (`a -> b` for each import inside the circle)."""
    lines = []
    for cycle in cycles:
        members = set(cycle)
        edges = [f"    {a} -> {b}" for a in cycle for b in sorted(graph[a] & members)]
        lines.append(
            f"import circle of {len(cycle)} modules: {', '.join(cycle)}\n" + "\n".join(edges)
        )
    return "\n".join(lines)


def test_no_import_circles():
    graph = import_graph()
    cycles = import_cycles()
    assert cycles == [], explain(cycles, graph)


def test_the_rollout_backends_import_only_the_interface_module():
    graph = import_graph()
    assert "judo.core.rollouts.backend" in graph["judo.core.rollouts.rollout"]
    assert "judo.core.rollouts.backend" in graph["judo.core.rollouts.warp_rollout"]
    assert "judo.core.rollouts.warp_rollout" not in graph["judo.core.rollouts.rollout"]
    assert "judo.core.rollouts.rollout" not in graph["judo.core.rollouts.warp_rollout"]
    assert not graph["judo.core.rollouts.backend"] & {
        "judo.core.rollouts.rollout",
        "judo.core.rollouts.warp_rollout",
    }
    # the factory names both backends by string, counted as imports; neither backend imports the
    # factory
    factory = "judo.core.rollouts.factory"
    assert {"judo.core.rollouts.rollout", "judo.core.rollouts.warp_rollout"} <= graph[factory]
    assert not any(
        factory in graph[m]
        for m in ("judo.core.rollouts.rollout", "judo.core.rollouts.warp_rollout")
    )
    assert not [
        cycle for cycle in import_cycles() if any(m.startswith("judo.core.") for m in cycle)
    ]


def write_package(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_the_circle_finder_sees_imports_inside_functions_relative_ones_and_names_the_edges(
    tmp_path,
):
    write_package(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/a.py": "from pkg.b import thing\n",
            # closes a <-> b from inside a function
            "pkg/b.py": "def late():\n    from . import a\n",
            "pkg/c.py": "import pkg.a\nfrom typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    "
            "import pkg.d\n",
            "pkg/d.py": "from pkg import c\n",  # c <-> d through a TYPE_CHECKING import
            "pkg/e.py": "import pkg.c\nimport os\n",  # imports into a circle, is in none
            "pkg/sub/__init__.py": "from .f import g\n",
            "pkg/sub/f.py": "from .. import sub\n",  # sub <-> sub.f through relative imports
            "pkg/self.py": "import pkg.self\n",
        },
    )
    cycles = import_cycles(tmp_path, "pkg")
    assert cycles == [
        ["pkg.a", "pkg.b"],
        ["pkg.c", "pkg.d"],
        ["pkg.self"],
        ["pkg.sub", "pkg.sub.f"],
    ]
    text = explain(cycles, import_graph(tmp_path, "pkg"))
    assert (
        "import circle of 2 modules: pkg.a, pkg.b\n    pkg.a -> pkg.b\n    pkg.b -> pkg.a" in text
    )


def lines_over_the_limit() -> dict[str, int]:
    """Each file in src/judo over MAX_LINES -> its lines."""
    over = {}
    for path in sorted((SRC / PACKAGE).rglob("*.py")):
        lines = len(path.read_text().splitlines())
        if lines > LONGER_FILES.get(path.relative_to(SRC / PACKAGE).as_posix(), MAX_LINES):
            over[path.relative_to(SRC / PACKAGE).as_posix()] = lines
    return over


def test_no_file_is_over_its_line_limit():
    over = lines_over_the_limit()
    assert not over, f"files over {MAX_LINES} lines (or their own limit in LONGER_FILES): {over}"


MAX_WIDTH = 100
"""Most characters in a line: ruff's E501 holds it, `# noqa: E501` marks the rare exception."""


def test_the_linter_holds_lines_to_100_characters_and_few_are_excused():
    config = (SRC.parent / "pyproject.toml").read_text()
    assert re.search(rf"(?m)^line-length = {MAX_WIDTH}$", config)
    assert re.search(rf"(?m)^max-line-length = {MAX_WIDTH}\b", config)
    assert "E501" not in re.search(r"(?ms)^\[tool\.ruff\.lint\]$(.*?)^\[", config).group(1)
    total = wide = 0
    for path in (SRC / PACKAGE).rglob("*.py"):
        lines = path.read_text().splitlines()
        total += len(lines)
        wide += sum(len(line) > MAX_WIDTH for line in lines)
    assert total > 10_000
    assert wide <= 0.02 * total, f"{wide} of {total} lines are over {MAX_WIDTH} characters"


APP_MODULES = 11
"""Most modules in the app package (src/judo/runtime, its gui/ and __init__ aside): a few rooms,
each one idea."""


def test_the_app_is_a_few_rooms():
    modules = sorted(
        p.stem for p in (SRC / PACKAGE / "runtime").glob("*.py") if p.name != "__init__.py"
    )
    assert 8 <= len(modules) <= APP_MODULES, (
        f"{len(modules)} app modules (at most {APP_MODULES}): {modules}"
    )


LIBRARY_LAYERS = (
    "judo.core",
    "judo.estimators",
    "judo.optimizers",
    "judo.tasks",
    "judo.safety",
    "judo.builtin",
    "judo.loop",
)
"""The library a notebook imports: what plans and estimates, and the closed loop that drives a plant
with it."""
APPLICATION_LAYERS = (
    "judo.ray_cluster",
    "judo.runtime",
    "judo.ros2",
    "judo.unitree",
    "judo.system_choice",
    "judo.cli_shared",
    "judo.evaluation",
    "judo.tuning",
    "judo.recording",
    "judo.collection",
    "judo.sysid",
    "judo.learning",
)
"""What runs it: Ray, the app and its loops, and the commands with what their command lines
share."""


def in_layer(module: str, layers: tuple[str, ...]) -> bool:
    return any(module == layer or module.startswith(layer + ".") for layer in layers)


def test_the_library_layers_never_import_the_runtime_or_the_commands():
    graph = import_graph()
    assert graph, "no judo modules found"
    upward = sorted(
        f"{module} imports {target}"
        for module, targets in graph.items()
        if in_layer(module, LIBRARY_LAYERS)
        for target in targets
        if in_layer(target, APPLICATION_LAYERS)
    )
    assert not upward, "\n".join(upward)


def test_the_loop_library_imports_nothing_from_the_app_the_gui_or_the_commands():
    """judo.loop is what a robot bridge and every command build on: it imports only the library
    below it."""
    graph = import_graph()
    loop_modules = [module for module in graph if in_layer(module, ("judo.loop",))]
    assert "judo.loop.closed_loop" in loop_modules and "judo.loop.system" in loop_modules
    allowed = (
        "judo.core",
        "judo.estimators",
        "judo.optimizers",
        "judo.tasks",
        "judo.safety",
        "judo.loop",
    )
    outside = sorted(
        f"{module} imports {target}"
        for module in loop_modules
        for target in graph[module]
        if not in_layer(target, allowed)
    )
    assert not outside, "\n".join(outside)


def test_nothing_below_learning_imports_it():
    """distill sits on top: it reads datasets and runs collect and evaluate; nothing else imports
    it."""
    graph = import_graph()
    upward = sorted(
        f"{module} imports {target}"
        for module, targets in graph.items()
        if not in_layer(module, ("judo.learning",)) and module != "judo.__main__"
        for target in targets
        if in_layer(target, ("judo.learning",))
    )
    assert not upward, "\n".join(upward)


TOP = ("judo", "judo.__main__")
"""The package itself and `python -m judo`: they gather everything, so they may import anything."""
PACKAGE_ORDER = (
    "judo.version",
    "judo.core",
    "judo.estimators",
    "judo.optimizers",
    "judo.tasks",
    "judo.safety",
    "judo.builtin",
    "judo.loop",
    "judo.ray_cluster",
    "judo.ros2",
    "judo.unitree",
    "judo.system_choice",
    "judo.cli_shared",
    "judo.evaluation",
    "judo.recording",
    "judo.collection",
    "judo.sysid",
    "judo.tuning",
    "judo.learning",
    "judo.runtime",
)
"""judo's packages (and top-level modules), lowest first: each imports only those before it, lazy
imports included. The library (core < estimators, optimizers < tasks), the closed loop (judo.loop),
then what runs it: Ray, the bridges, the command lines' shared pieces, and the commands; recording
writes collect's files (with evaluate's rewards), collect runs evaluate's seeded episodes, sysid
reads and writes collect's files, tune runs none of collect's, and distill runs both. The app sits
on top: it records into collect's files and replays them."""


def package_of(module: str, package: str = PACKAGE) -> str:
    """The package a module counts for: "judo.core.rollouts.rollout" -> "judo.core"; a module
    directly in the package ("judo.ray_cluster", "judo.__main__") and the package itself count for
    themselves."""
    parts = module.split(".")
    return module if len(parts) <= 2 or parts[0] != package else ".".join(parts[:2])


def package_graph(
    graph: dict[str, set[str]], package: str = PACKAGE
) -> dict[tuple[str, str], list[str]]:
    """(importing package, imported package) -> the module imports that make the edge ("a.x ->
    b.y"), for each pair of different packages; built from `graph` (every import, lazy ones
    included)."""
    edges: dict[tuple[str, str], list[str]] = {}
    for module, targets in graph.items():
        for target in sorted(targets):
            edge = (package_of(module, package), package_of(target, package))
            if edge[0] != edge[1]:
                edges.setdefault(edge, []).append(f"{module} -> {target}")
    return edges


def package_cycles(
    edges: dict[tuple[str, str], list[str]], allowed: Set[tuple[str, str]] = frozenset()
) -> str:
    """Each package-level import circle of `edges` (less the `allowed` ones), with the module
    imports that close it; "" when there is none."""
    nodes = {node for edge in edges for node in edge}
    graph = {node: {b for (a, b) in edges if a == node and (a, b) not in allowed} for node in nodes}
    lines = []
    for cycle in sorted(c for c in strongly_connected_components(graph) if len(c) > 1):
        lines.append(f"package import circle: {', '.join(cycle)}")
        lines += [
            f"    {line}"
            for a in cycle
            for b in sorted(graph[a] & set(cycle))
            for line in edges[a, b]
        ]
    return "\n".join(lines)


def upward_imports(
    edges: dict[tuple[str, str], list[str]],
    order: tuple[str, ...],
    allowed: Set[tuple[str, str]] = frozenset(),
) -> list[str]:
    """Every module import from a package in `order` to one above it (an edge not in `allowed`)."""
    rank = {name: index for index, name in enumerate(order)}
    return [
        f"{line}  ({a} is below {b} in the order)"
        for (a, b), lines in sorted(edges.items())
        if a in rank and b in rank and rank[b] > rank[a] and (a, b) not in allowed
        for line in lines
    ]


def test_no_package_level_import_circles_counting_lazy_imports():
    cycles = package_cycles(package_graph(import_graph()))
    assert not cycles, cycles


def test_the_packages_import_only_downward_in_their_order():
    graph = import_graph()
    packages = {package_of(module) for module in graph}
    assert packages - set(TOP) == set(PACKAGE_ORDER), (
        "place each package of src/judo in PACKAGE_ORDER"
    )
    upward = upward_imports(package_graph(graph), PACKAGE_ORDER)
    assert not upward, "\n".join(upward)


def test_no_module_imports_the_root_package():
    """`import judo` or `from judo import make_controller` in a module of judo: the root package
    gathers everything (the app included), so such a module depends on all of judo. It imports from
    the defining module instead."""
    graph = import_graph()
    importers = sorted(
        module
        for module, targets in graph.items()
        if PACKAGE in targets and module != "judo.__main__"
    )
    assert not importers, f"these import the root judo package: {importers}"


def test_the_package_check_sees_a_lazy_import_that_the_module_check_cannot(tmp_path):
    write_package(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/low/__init__.py": "",
            # low -> high, inside a function
            "pkg/low/a.py": "def late():\n    from pkg.high import c\n",
            "pkg/low/d.py": "",
            "pkg/high/__init__.py": "",
            "pkg/high/b.py": "from pkg.low import d\n",  # high -> low
            "pkg/high/c.py": "",
        },
    )
    assert import_cycles(tmp_path, "pkg") == []  # no module imports one that imports it back
    edges = package_graph(import_graph(tmp_path, "pkg"), "pkg")
    text = package_cycles(edges)
    assert text.startswith("package import circle: pkg.high, pkg.low\n")
    assert "    pkg.low.a -> pkg.high.c" in text and "    pkg.high.b -> pkg.low.d" in text
    assert upward_imports(edges, ("pkg.low", "pkg.high")) == [
        "pkg.low.a -> pkg.high.c  (pkg.low is below pkg.high in the order)"
    ]
    assert package_cycles(edges, {("pkg.low", "pkg.high")}) == ""


def control_update_files() -> list[str]:
    """The files docs/architecture.md lists on the path of one control update ("One control update,
    file by file")."""
    text = (SRC.parent / "docs" / "architecture.md").read_text()
    section = text.split("## One control update, file by file", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| ") and line[2:3].isdigit()]
    files = [
        name
        for row in rows
        for name in re.findall(r"`([\w/]+\.py)`", row.split("|")[2] + row.split("|")[3])
    ]
    return list(dict.fromkeys(files))


def test_the_documented_path_of_a_control_update_names_files_that_exist():
    files = control_update_files()
    # at most 15 files from the command line to the served action
    assert 10 <= len(files) <= 15, files
    missing = [name for name in files if not (SRC / PACKAGE / name).is_file()]
    assert not missing, f"docs/architecture.md names files that are not in src/judo: {missing}"
    assert "loop/closed_loop.py" in files and "core/controller.py" in files


def test_the_loop_library_imports_only_contracts_and_few_modules_beyond_them():
    """What loop/'s own files import, followed transitively (lazy imports and importlib strings
    counted): the judo modules outside judo.loop that a robot integrator's loop depends on, at most
    `target`: the contracts (task, planner, estimator, reading, spline, errors) and what they stand
    on (config, model, sensors). The loop imports no concrete controller, rollout machinery,
    registry, safety layer, bridge or app: the safety objects are handed in (judo.loop.guard's
    protocols), the Task types its low-level policy and the Planner its config by protocols."""
    target = 10
    graph = import_graph()
    loop = [module for module in graph if in_layer(module, ("judo.loop",))]
    concrete = (
        "judo.core.controller",
        "judo.core.rollouts",
        "judo.core.policies",
        "judo.core.configuration.registry",
    )
    direct = sorted(
        f"{module} imports {target}"
        for module in loop
        for target in graph[module]
        if in_layer(target, concrete)
    )
    assert not direct, "\n".join(direct)
    closure: set[str] = set()
    todo = list(loop)
    while todo:
        for imported in graph[todo.pop()] - closure:
            closure.add(imported)
            todo.append(imported)
    outside = sorted(module for module in closure if not in_layer(module, ("judo.loop",)))
    assert len(outside) <= target, (
        f"{len(outside)} judo modules in the loop's import closure: {outside}"
    )


def test_the_circle_finder_counts_a_module_named_for_importlib(tmp_path):
    write_package(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/low.py": 'import importlib\nPLUGINS = {"high": "pkg.high.Thing"}\n'
            "def load(name):\n    module, _, attr = PLUGINS[name].rpartition('.')\n"
            "    return getattr(importlib.import_module(module), attr)\n",
            # low <-> high through the string
            "pkg/high.py": "from pkg.low import load\nclass Thing: ...\n",
            # "module:attr" counts without importlib
            "pkg/table.py": 'COMMANDS = {"run": "pkg.cmd:main"}\n',
            "pkg/cmd.py": "import pkg.table\ndef main(): ...\n",  # table <-> cmd
            "pkg/quiet.py": '"""pkg.cmd"""\nimport logging\nlog = '
            'logging.getLogger("pkg.cmd")\nNAME = '
            '"pkg.cmd"\n',
            "pkg/dot.py": "import importlib\nimport pkg.doc\nNAME "
            '= f"pkg.{1}"\nROOT = "pkg.nothing"\n',
            "pkg/doc.py": '"""Loaded as "pkg.dot" by name."""\nimport pkg.quiet\n',
        },
    )
    graph = import_graph(tmp_path, "pkg")
    assert graph["pkg.low"] == {"pkg.high"} and graph["pkg.table"] == {"pkg.cmd"}
    # a docstring and a logger's or a constant's name, in a module with no loader
    assert graph["pkg.quiet"] == set()
    # an f-string's piece and a name that is no module are no edge
    assert graph["pkg.dot"] == {"pkg.doc"}
    assert import_cycles(tmp_path, "pkg") == [["pkg.cmd", "pkg.table"], ["pkg.high", "pkg.low"]]


PACKAGE_INIT = "__init__.py"


def test_no_package_init_but_the_root_imports_a_name():
    """One public path per name: `judo.X` for users (src/judo/__init__.py), else the module that
    defines it. A package's __init__.py holds its docstring only (judo.builtin registers the
    built-in tasks, optimizers and estimators; `import judo` calls it)."""
    importing = {}
    for path in sorted((SRC / PACKAGE).rglob(PACKAGE_INIT)):
        if path.parent == SRC / PACKAGE:
            continue
        tree = ast.parse(path.read_text(), str(path))
        found = [
            ast.unparse(node)
            for node in ast.walk(tree)
            if isinstance(node, (ast.Import, ast.ImportFrom))
        ]
        if found:
            importing[path.relative_to(SRC).as_posix()] = found
    assert not importing, (
        f"package __init__.py files that import (import from the defining module): {importing}"
    )


def re_exports(root: Path = SRC, package: str = PACKAGE) -> dict[str, list[str]]:
    """Each module of `package` but the root -> the imported names it re-exports: those its
    `__all__` lists, and those imported as themselves (`from a import b as b`, `import a as a`)."""
    found: dict[str, list[str]] = {}
    for path in sorted((root / package).rglob("*.py")):
        if path == root / package / PACKAGE_INIT:
            continue
        tree = ast.parse(path.read_text(), str(path))
        imported: set[str] = set()
        names: list[str] = []
        for node in tree.body:
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                imported |= {alias.asname or alias.name.partition(".")[0] for alias in node.names}
                names += [
                    alias.asname
                    for alias in node.names
                    if alias.asname and alias.asname == alias.name
                ]
            elif isinstance(node, ast.Assign) and any(
                getattr(t, "id", None) == "__all__" for t in node.targets
            ):
                listed = [
                    e.value for e in getattr(node.value, "elts", []) if isinstance(e, ast.Constant)
                ]
                names += [name for name in listed if name in imported]
        if names:
            found[module_name(path, root)] = sorted(set(names))
    return found


def test_no_module_re_exports_an_imported_name():
    exported = re_exports()
    assert not exported, f"import these from the module that defines them, not from: {exported}"


def test_the_re_export_finder_sees_all_and_redundant_aliases(tmp_path):
    write_package(
        tmp_path,
        {
            # the root is the user surface
            "pkg/__init__.py": "from pkg.a import f\n__all__ = ['f']\n",
            "pkg/a.py": "def f(): ...\n__all__ = ['f']\n",
            "pkg/b.py": "from pkg.a import f\nfrom os import sep as sep\n__all__ = ['f', 'g']\ndef "
            "g(): ...\n",
        },
    )
    assert re_exports(tmp_path, "pkg") == {"pkg.b": ["f", "sep"]}


TYPE_IGNORES = 2
"""Most `type: ignore` comments in src/judo: the typing is fixed instead (a Protocol, a Literal, a
cast of what was just checked)."""


def test_few_type_ignores():
    found = [
        f"{path.relative_to(SRC).as_posix()}:{number}"
        for path in sorted((SRC / PACKAGE).rglob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if re.search(r"#\s*type:\s*ignore", line)
    ]
    assert len(found) <= TYPE_IGNORES, (
        f"{len(found)} type: ignore (at most {TYPE_IGNORES}): {found}"
    )


PACKAGE_MODULES = 20
"""Most files in one package of src/judo (its __init__.py counted): a room a reader can take in at
once."""


def test_no_package_holds_more_than_twenty_modules():
    sizes = {
        directory.relative_to(SRC).as_posix(): len(list(directory.glob("*.py")))
        for directory in sorted({path.parent for path in (SRC / PACKAGE).rglob("*.py")})
    }
    over = {name: size for name, size in sizes.items() if size > PACKAGE_MODULES}
    assert not over, f"packages over {PACKAGE_MODULES} modules: {over}"
    assert max(sizes.values()) >= 10  # the walk found the packages


KIND_BRANCHES = (
    re.compile(r"optimizer is (not )?None"),
    re.compile(r"isinstance\([^)]*\bDynamicsTask\b"),
    re.compile(r"isinstance\([^)]*\bPolicyController\b"),
)
"""Lines that branch on the kind of planner or task instead of asking it (`PlannerKind`,
`spec.runs_mpc`, the task's own hooks); the rule of benchmarks/house_figures.py (its KIND_PATTERNS
and `policy_comparison`), copied here."""


def kind_branches(root: Path = SRC, package: str = PACKAGE) -> list[str]:
    """ "path:line: code" of each line (its code before a `  #` comment) that branches on a planner's or task's kind:
    a KIND_BRANCHES match, or a ==, != or `in` comparison with "policy" or a module constant bound
    to it."""  # noqa: E501
    texts = {path: path.read_text() for path in sorted((root / package).rglob("*.py"))}
    # NAME = "policy"
    bound = re.compile(r'^([A-Z_][A-Z0-9_]*)\s*(?::[^=]*)?=\s*"policy"\s*$', re.MULTILINE)
    constants = {name for text in texts.values() for name in bound.findall(text)}
    names = "|".join(re.escape(name) for name in ['"policy"', *sorted(constants)])
    policy = re.compile(
        rf"(?:==|!=)\s*(?:{names})\b|(?:{names})\s*(?:==|!=|\bnot "
        rf"in\b|\bin\b)|\bin\s*[(\[{{][^)\]}}]*(?:{names})"
    )
    return [
        f"{path.relative_to(root).as_posix()}:{number}: {line.strip()}"
        for path, text in texts.items()
        for number, line in enumerate(text.splitlines(), 1)
        if any(pattern.search(line.split("  #")[0]) for pattern in (*KIND_BRANCHES, policy))
    ]


def test_no_branch_on_the_kind_of_planner_or_task(tmp_path):
    write_package(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/a.py": 'POLICY = "policy"\nif spec.optimizer is None:\n    pass\nok = name == '
            "POLICY\n",
            "pkg/b.py": "if isinstance(task, DynamicsTask):\n    pass\nx = 1  # optimizer is None "
            "here\n",
        },
    )
    assert [line.split(":")[0:2] for line in kind_branches(tmp_path, "pkg")] == [
        ["pkg/a.py", "2"],
        ["pkg/a.py", "4"],
        ["pkg/b.py", "1"],
    ]
    found = kind_branches()
    assert not found, (
        f"{len(found)} branches on the kind of planner or task (ask it instead):\n"
        + "\n".join(found)
    )


POLLED_COUNTER = re.compile(
    r"self\._\w*(?:version|generation|edits|resets)\w*\s*!="
    r"|(?<!\.value\.generation) != self\._\w*(?:version|generation|edits|resets)"
)
"""A GUI field compared with `!=` to see that the app's state changed (the rule of
benchmarks/house_figures.py). A delivered reading's or plan's own `.value.generation` compared with
the session shown is not a poll: it drops news of a session the GUI no longer shows."""


def test_the_gui_subscribes_and_polls_no_change_counter():
    """The GUI learns of new readings, plans, edits, resets and switches from the App's `on_*`
    callbacks."""
    gui = SRC / PACKAGE / "runtime" / "gui"
    polled = [
        f"{path.name}:{number}: {line.strip()}"
        for path in sorted(gui.glob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if POLLED_COUNTER.search(line)
    ]
    assert not polled, "\n".join(polled)
    # the rule sees a counter
    assert POLLED_COUNTER.search("if state.version != self._state_version:")
    # and news of a session gone
    assert not POLLED_COUNTER.search("if state.value.generation != self._generation:")


def test_one_module_per_command_named_after_it():
    """`python -m judo NAME` runs the module named NAME (gait-search: gait_search); no module is a
    bare `cli.py`."""
    import judo.__main__ as main

    clis = sorted(
        p.relative_to(SRC).as_posix()
        for p in (SRC / PACKAGE).rglob("*.py")
        if p.stem.endswith("cli")
    )
    assert not clis, f"name each command's module after its command: {clis}"
    for command, target in main.COMMANDS.items():
        module = target.partition(":")[0]
        # ros2/plant.py's command, run with the Unitree protocol's robot beside it
        if command == "plant":
            assert (
                target == "judo.unitree.robot:main"
                and (SRC / PACKAGE / "ros2" / "plant.py").is_file()
            )
            continue
        assert module.rsplit(".", 1)[-1] == command.replace("-", "_"), (command, target)
        assert (SRC / (module.replace(".", "/") + ".py")).is_file(), target
    assert main.APP.startswith("judo.runtime.launch:")


FILES_PER_UPDATE = 15
"""Most judo files whose code runs during steady-state updates of cartpole with mppi in the app
(28 before the house was rebuilt, 21 after the first round, 17 before the watchdog joined the
loop's timing and the threads' shared machinery joined one room: the target is 15)."""


# about 6 s (the app warms up for 4 s before it records): it holds the house's update path
def test_files_crossed_lists_each_file_with_its_callers_and_few_files_run_per_update():
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "files_crossed.py"),
            "--seconds",
            "0.3",
            "--callers",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        env={
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]),
        },
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[-1].endswith("files run code during steady-state updates")
    files = [line.split()[-1] for line in lines if re.fullmatch(r" {6,10}[0-9.]+  \S+", line)]
    assert len(files) == int(lines[-1].split()[0])
    assert len(files) <= FILES_PER_UPDATE, files
    assert any(line.strip().endswith("core/controller.py") for line in lines)
    assert any("update_action <- loop/closed_loop.py:plan" in line for line in lines)
