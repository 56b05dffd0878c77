"""Check that every Python file changed since a git revision behaves as it did there.

    python tools/width/astcheck.py [--base HEAD] [--repo .]

Same AST and the same compiled constants, ignoring only comments, docstring whitespace and how
string literals are cut into implicitly concatenated pieces (equiv.compare). Exit 1 and name the
files that differ.
"""

import argparse
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from equiv import compare


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--base", default="HEAD")
    parser.add_argument("--repo", default=".")
    args = parser.parse_args()
    started = time.perf_counter()
    git = ["git", "-C", args.repo]
    names = subprocess.run(
        git + ["diff", "--name-only", "--diff-filter=M", args.base, "--", "*.py"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    bad = 0
    for name in names:
        before = subprocess.run(
            git + ["show", f"{args.base}:{name}"], check=True, capture_output=True, text=True
        ).stdout
        with open(os.path.join(args.repo, name), encoding="utf-8") as f:
            after = f.read()
        problem = compare(before, after, name)
        if problem:
            bad += 1
            print(f"{name}: {problem}")
    print(
        f"{len(names) - bad} of {len(names)} changed files behave the same "
        f"({time.perf_counter() - started:.1f} s)"
    )
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
