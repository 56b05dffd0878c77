"""The objects a config file names by dotted import path ([custom_tasks.NAME] task =
"my_module.MyTask"), imported with errors that name the part that failed and show the user's own
frames, and a module beside the file that an installed one shadows refused."""

import importlib
import sys
import traceback
from pathlib import Path
from typing import Any

from judo.core.errors import JudoError


def import_dotted(dotted: str, key: str, folder: Path) -> Any:
    """The object at the dotted import path `dotted` (named by `key` = "..."), or a JudoError naming
    the part that failed. An error raised while importing the user's module keeps the user's own
    frames (file, line, source) and the error, and drops judo's and importlib's."""
    module_name, _, attribute = dotted.rpartition(".")
    named = f'{key} = "{dotted}"'
    if not module_name:
        raise JudoError(f"{named} is not a dotted import path like 'my_module.MyClass'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as err:
        # the named module itself is missing
        if err.name is not None and module_name.startswith(err.name):
            raise JudoError(
                f"cannot import module {module_name!r} (named by {named}): {err}"
            ) from None
        raise JudoError(
            f"importing module {module_name!r} (named by {named}) failed:\n{_user_error(err)}"
        ) from None
    except Exception as err:  # a SyntaxError or any error raised by the module's own code
        raise JudoError(
            f"importing module {module_name!r} (named by {named}) failed:\n{_user_error(err)}"
        ) from None
    _check_not_shadowed(module_name, folder, named)
    if not hasattr(module, attribute):
        raise JudoError(f"module {module_name!r} has no attribute {attribute!r} (named by {named})")
    return getattr(module, attribute)


def _user_error(err: BaseException) -> str:
    """`err` formatted like a traceback, but with only the frames of the user's files."""
    judo_dir = str(Path(__file__).resolve().parents[1])
    frames = [
        frame
        for frame in traceback.extract_tb(err.__traceback__)
        if not frame.filename.startswith((judo_dir, "<frozen "))
        and "importlib" not in frame.filename
    ]
    lines = traceback.format_list(frames) + traceback.format_exception_only(type(err), err)
    return "".join(lines).rstrip("\n")


def _check_not_shadowed(module_name: str, folder: Path, named: str) -> None:
    """Raise JudoError if a module of this name lies beside the config file but an installed one was
    imported."""
    top = module_name.partition(".")[0]
    beside = [
        candidate
        for candidate in (folder / f"{top}.py", folder / top / "__init__.py")
        if candidate.exists()
    ]
    loaded = getattr(sys.modules.get(top), "__file__", None)
    if beside and loaded is not None and Path(loaded).resolve() != beside[0].resolve():
        raise JudoError(
            f"{named} names {beside[0]}, but {top!r} is also an installed module ({loaded}), "
            "which comes first; "
            "rename your module"
        )
