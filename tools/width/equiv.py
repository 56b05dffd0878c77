"""Behaviour checks for a rewrapped Python file: the same AST and the same compiled constants.

Allowed differences: comments, the whitespace inside docstrings (any statement that is a bare
string), and how a string literal is cut into implicitly concatenated pieces (the AST already joins
those).
"""

import ast
import types


def _norm(text: str) -> str:
    return " ".join(text.split())


def _doc_nodes(tree: ast.AST) -> list[ast.Constant]:
    return [
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Expr)
        and isinstance(node.value, ast.Constant)
        and isinstance(node.value.value, str)
    ]


def normalised_dump(source: str) -> str:
    """The AST of `source` with every bare-string statement's whitespace collapsed, without
    positions."""
    tree = ast.parse(source)
    for const in _doc_nodes(tree):
        const.value = _norm(const.value)
    return ast.dump(tree, include_attributes=False)


def _constants(code: types.CodeType, out: list) -> list:
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            out.append(
                ("code", const.co_name, const.co_qualname if hasattr(const, "co_qualname") else "")
            )
            _constants(const, out)
        else:
            out.append(const)
    return out


def _same_const(a, b, docs: set[str]) -> bool:
    if type(a) is not type(b):
        return False
    if isinstance(a, str) and a != b:
        return _norm(a) == _norm(b) and _norm(a) in docs
    if isinstance(a, (tuple, frozenset)):
        if len(a) != len(b):
            return False
        if isinstance(a, frozenset):
            return a == b
        return all(_same_const(x, y, docs) for x, y in zip(a, b, strict=False))
    if isinstance(a, float) and a != a:
        return b != b
    return a == b


def compare(before: str, after: str, filename: str = "<file>") -> str | None:
    """None when `after` behaves as `before`; otherwise a line that says what differs."""
    try:
        tree_after = normalised_dump(after)
    except SyntaxError as err:
        return f"after does not parse: {err}"
    if normalised_dump(before) != tree_after:
        return "AST differs"
    docs = {_norm(c.value) for c in _doc_nodes(ast.parse(before))}
    consts_before = _constants(compile(before, filename, "exec", dont_inherit=True), [])
    consts_after = _constants(compile(after, filename, "exec", dont_inherit=True), [])
    if len(consts_before) != len(consts_after):
        return "number of compiled constants differs"
    for a, b in zip(consts_before, consts_after, strict=False):
        if not _same_const(a, b, docs):
            return f"compiled constant differs: {a!r} != {b!r}"
    return None
