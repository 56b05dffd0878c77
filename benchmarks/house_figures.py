"""The figures of the house: how a checkout of judo is laid out, measured from its source.

    PYTHONPATH=src python benchmarks/house_figures.py [--root PATH] [--compare ROOT] [--skip-run] [--show]

Each figure is one line, `name: value`, counted the same way on any checkout (old ones too):

- files run per update: the last line of that checkout's benchmarks/files_crossed.py (cartpole,
  mppi), run with its own src on PYTHONPATH (a few seconds; `--skip-run` leaves it out);
- loop import closure: the judo modules outside judo.loop reached from loop/'s files by following
  every import statement (at module level, in functions, under TYPE_CHECKING), as
  tests/test_architecture.py reads them; in brackets, with the package __init__ files Python runs on
  the way (all but the root package's);
- largest package: the most .py files directly in one directory of src/judo; largest file: its most
  lines;
- kind branches: lines with `optimizer is None` / `optimizer is not None`, a ==, != or `in`
  comparison with "policy" or with a module constant bound to "policy", `isinstance(...,
  DynamicsTask)`, `isinstance(..., PolicyController)`;
- GUI polled counters: lines of runtime/gui/*.py that compare `self._X` with `!=` (either side), X
  naming a version, generation, edits or resets: a counter the GUI keeps to see that the app's state
  changed (a delivered reading's or plan's own `.value.generation` compared with the session shown
  is a filter on news, not a poll);
- `type: ignore` in src/judo, and lines over 100 characters there (of all lines in its .py files);
- re-exports: package __init__.py files other than judo/__init__.py that import names (not
  submodules) from judo, and how many names;
- modules named cli.py, and assignments to TIME_TOLERANCE at the start of a line.

With `--compare ROOT`, ROOT is "before" and `--root` "after", side by side; `--show` lists the lines
that the branch and counter figures count (of `--root`).
"""  # noqa: E501

import argparse
import ast
import os
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
PACKAGE = "judo"
KIND_PATTERNS = {
    "is None": re.compile(r"optimizer is (not )?None"),
    "DynamicsTask": re.compile(r"isinstance\([^)]*\bDynamicsTask\b"),
    "PolicyController": re.compile(r"isinstance\([^)]*\bPolicyController\b"),
}
COUNTER = r"self\._\w*(?:version|generation|edits|resets)\w*"
POLLED = re.compile(rf"{COUNTER}\s*!=|(?<!\.value\.generation) != {COUNTER}")
TOLERANCE = re.compile(r"^\s*TIME_TOLERANCE\s*(:[^=]*)?=[^=]")


def sources(root: Path) -> dict[str, Path]:
    """Each module of src/judo under `root` -> its file ("judo.core.task" ->
    .../judo/core/task.py)."""
    src = root / "src"
    found = {}
    for path in sorted((src / PACKAGE).rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def imports_of(path: Path, module: str, modules: set[str]) -> set[str]:
    """The modules among `modules` that `path` imports anywhere; a name imported from a module
    counts as that module, and a dotted name as its longest prefix that is a module (the rule of
    tests/test_architecture.py)."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]

    def known(dotted: str) -> str | None:
        while dotted and dotted not in modules:
            dotted = dotted.rpartition(".")[0]
        return dotted or None

    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join([*anchor, *([base] if base else [])])
            targets = [
                f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names
            ]
        else:
            continue
        found.update(target for name in targets if (target := known(name)))
    return found


def loop_closure(files: dict[str, Path]) -> tuple[int, int]:
    """(modules outside judo.loop reached from loop/'s files, the same with the package __init__
    files on the way)."""
    graph = {module: imports_of(path, module, set(files)) for module, path in files.items()}
    inside = [m for m in graph if m == "judo.loop" or m.startswith("judo.loop.")]
    seen, todo = set(inside), list(inside)
    while todo:
        for successor in graph[todo.pop()] - seen:
            seen.add(successor)
            todo.append(successor)
    outside = {
        m for m in seen if not (m == "judo.loop" or m.startswith("judo.loop.")) and m != PACKAGE
    }
    parents = {
        p
        for m in outside
        for p in (m.rsplit(".", k)[0] for k in range(1, m.count(".")))
        if p in graph
    }
    return len(outside), len(outside | parents)


def policy_names(texts: dict[str, str]) -> list[str]:
    """ "policy" and the module constants bound to it (`NAME = "policy"`)."""
    constants = set()
    for text in texts.values():
        constants.update(
            re.findall(r'^([A-Z_][A-Z0-9_]*)\s*(?::[^=]*)?=\s*"policy"\s*$', text, re.MULTILINE)
        )
    return ['"policy"', *sorted(constants)]


def policy_comparison(texts: dict[str, str]) -> re.Pattern:
    """What compares a name with "policy" (or its constant) by ==, != or in."""
    names = "|".join(re.escape(name) for name in policy_names(texts))
    return re.compile(
        rf"(?:==|!=)\s*(?:{names})\b|(?:{names})\s*(?:==|!=|\bnot in\b|\bin\b)"
        rf"|\bin\s*[(\[{{][^)\]}}]*(?:{names})"
    )


def matching(
    src: Path, files: dict[str, Path], texts: dict[str, str], pattern: re.Pattern, under: str = ""
) -> list[str]:
    """ "path:line: text" of each line (its code, before a comment) that `pattern` finds, in files
    under `under`."""
    found = []
    for module, path in files.items():
        where = path.relative_to(src).as_posix()
        if where.startswith(under):
            for number, line in enumerate(texts[module].splitlines(), 1):
                if pattern.search(line.split("  #")[0]):
                    found.append(f"{where}:{number}: {line.strip()}")
    return found


def reexports(files: dict[str, Path]) -> tuple[int, int]:
    """(package __init__ files but the root's that import names from judo, how many names they
    import)."""
    modules, count, names = set(files), 0, 0
    for module, path in files.items():
        if path.name != "__init__.py" or module == PACKAGE:
            continue
        here = 0
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.ImportFrom) and (
                node.level or (node.module or "").split(".")[0] == PACKAGE
            ):
                base = node.module or ""
                if node.level:
                    base = ".".join(
                        [*module.split(".")[: len(module.split(".")) - (node.level - 1)], base]
                    ).strip(".")
                here += sum(1 for a in node.names if f"{base}.{a.name}" not in modules)
        count, names = count + (here > 0), names + here
    return count, names


def files_crossed(root: Path) -> str:
    """The last line of `root`'s benchmarks/files_crossed.py, run with `root`'s src."""
    script = root / "benchmarks" / "files_crossed.py"
    if not script.exists():
        return "no benchmarks/files_crossed.py"
    env = {**os.environ, "PYTHONPATH": str(root / "src")}
    result = subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        env=env,
        cwd=root,
        timeout=600,
    )
    lines = result.stdout.strip().splitlines()
    if result.returncode != 0 or not lines:
        return f"failed ({result.returncode}): {result.stderr.strip().splitlines()[-1:]}"
    match = re.match(r"(\d+) files", lines[-1])
    return match.group(1) if match else lines[-1]


def figures(root: Path, run: bool = True) -> tuple[dict[str, str], list[str]]:
    """Each figure's name -> its value on the checkout at `root`, and the lines the branch and
    counter figures count."""
    files = sources(root)
    texts = {module: path.read_text() for module, path in files.items()}
    lines = [line for text in texts.values() for line in text.splitlines()]
    out = {}
    if run:
        out["files run per steady-state update"] = files_crossed(root)
    outside, with_parents = loop_closure(files)
    out["loop/ import closure (judo modules outside loop/)"] = (
        f"{outside} ({with_parents} with packages)"
    )
    per_dir: dict[Path, int] = {}
    for path in files.values():
        per_dir[path.parent] = per_dir.get(path.parent, 0) + 1
    biggest = max(per_dir, key=lambda d: (per_dir[d], str(d)))
    src = root / "src"
    out["largest package (.py files)"] = (
        f"{per_dir[biggest]} ({biggest.relative_to(src / PACKAGE).as_posix()})"
    )
    sizes = {path: len(texts[module].splitlines()) for module, path in files.items()}
    longest = max(sizes, key=lambda path: (sizes[path], str(path)))
    out["largest file (lines)"] = (
        f"{sizes[longest]} ({longest.relative_to(src / PACKAGE).as_posix()})"
    )
    patterns = {**KIND_PATTERNS, '"policy"': policy_comparison(texts)}
    branches = {name: matching(src, files, texts, pattern) for name, pattern in patterns.items()}
    detail = ", ".join(f"{name} {len(found)}" for name, found in branches.items())
    out["branches on planner or task kind"] = (
        f"{sum(len(found) for found in branches.values())} ({detail})"
    )
    polled = matching(src, files, texts, POLLED, "judo/runtime/gui/")
    out["GUI polled change counters"] = str(len(polled))
    shown = [line for found in branches.values() for line in found] + polled
    out["type: ignore"] = str(sum(line.count("type: ignore") for line in lines))
    long = sum(1 for line in lines if len(line) > 100)
    out["lines over 100 characters"] = (
        f"{long} of {len(lines)} ({100 * long / max(len(lines), 1):.1f}%)"
    )
    modules, names = reexports(files)
    out["re-exporting package __init__ files (names)"] = f"{modules} ({names} names)"
    out["modules named cli.py"] = str(sum(1 for p in files.values() if p.name == "cli.py"))
    out["TIME_TOLERANCE definitions"] = str(sum(1 for line in lines if TOLERANCE.match(line)))
    return out, shown


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--root", type=Path, default=HERE, help="a checkout of judo (default: this one)"
    )
    parser.add_argument(
        "--compare", type=Path, metavar="ROOT", help="a checkout to print beside --root, as before"
    )
    parser.add_argument(
        "--skip-run", action="store_true", help="leave out files_crossed.py (the slow figure)"
    )
    parser.add_argument(
        "--show", action="store_true", help="list the lines the branch and counter figures count"
    )
    args = parser.parse_args()
    for root in [args.root, args.compare]:
        if root is not None and not (root / "src" / PACKAGE).is_dir():
            parser.error(f"{root} has no src/{PACKAGE}")
    after, shown = figures(args.root.resolve(), run=not args.skip_run)
    if args.compare is None:
        print(f"figures of {args.root}")
        for name, value in after.items():
            print(f"{name}: {value}")
        print(
            *(f"  {line}" for line in shown if args.show),
            sep="\n",
            end="\n" if args.show and shown else "",
        )
        return
    before, _ = figures(args.compare.resolve(), run=not args.skip_run)
    width = max(len(name) for name in after) + 1
    column = max(len(value) for value in before.values())
    print(f"{'':{width}}  {'before (' + str(args.compare) + ')':{column}}  after ({args.root})")
    for name, value in after.items():
        print(f"{name + ':':{width}}  {before.get(name, '-'):{column}}  {value}")


if __name__ == "__main__":
    main()
