"""The docstring line under each dataclass field, read from the source: the GUI's hover hints and
the CLIs' help."""

import ast
import dataclasses
import functools
import inspect
import textwrap


@functools.cache
def field_docs(config_cls: type) -> dict[str, str]:
    """Field name -> the string literal right below its annotation, over `config_cls` and its bases.

    Fields without one, and classes whose source cannot be read, are left out.
    """
    docs: dict[str, str] = {}
    for cls in reversed(config_cls.__mro__):
        if not dataclasses.is_dataclass(cls):
            continue
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
        except (OSError, TypeError, SyntaxError):
            continue
        body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
        for node, after in zip(body, body[1:], strict=False):
            if (
                isinstance(node, ast.AnnAssign)
                and isinstance(node.target, ast.Name)
                and isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant)
                and isinstance(after.value.value, str)
            ):
                docs[node.target.id] = inspect.cleandoc(after.value.value)
    return docs
