"""Rewrap Python sources to a line width without changing what they do.

    python tools/width/rewrap.py [--width 100] [--check] [--verbose] PATH...

Passes, each checked on its own (a pass whose result fails the check is dropped for that file):
  1. docstrings: prose paragraphs re-flowed at the docstring's indent (lists get a hanging indent;
     code blocks, tables, doctests and ``` fences stay as they are). Field docstrings, the string
     right under a dataclass field, are left alone unless --field-docs: tyro prints their line
     breaks in --help.
  2. long string literals in code: cut at a space into adjacent literals (implicit concatenation),
     inside the brackets around them or inside new parentheses; the value is the same.
  3. trailing comments that push a line over the width: moved onto their own line above the code.
  4. full-line comments over the width: runs of prose comment lines re-flowed at the same indent.
Run `ruff format --line-length WIDTH` afterwards: it re-lays the code lines that are still long.
Every file written is checked with equiv.compare (same AST and compiled constants, docstring
whitespace aside).
"""

import argparse
import ast
import io
import os
import re
import sys
import time
import tokenize

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from equiv import compare

PRAGMA = re.compile(r"^#\s*(noqa|type:|pragma|fmt:|pyright:|isort:|ruff:|mypy:|-\*-|!)|^#!")
LIST_MARK = re.compile(r"^([-*+]|\d+[.)]|\(\d+\)|[a-z][.)])\s+")
SKIP_DIRS = {
    ".venv",
    ".git",
    "__pycache__",
    "build",
    "dist",
    ".mypy_cache",
    ".ruff_cache",
    "node_modules",
}


def wrap_words(words: list[str], first: int, rest: int) -> list[str]:
    """Greedy fill: the first line holds `first` columns, the others `rest`; a word longer than a
    line stays whole."""
    lines: list[str] = []
    cur = ""
    limit = first
    for word in words:
        if not cur:
            cur = word
        elif len(cur) + 1 + len(word) <= limit:
            cur += " " + word
        else:
            lines.append(cur)
            cur = word
            limit = rest
    if cur:
        lines.append(cur)
    return lines


def _is_header(text: str) -> bool:
    """A short line that ends with a colon (`Args:`, `Example:`): what follows starts a new
    paragraph."""
    return text.endswith(":") and (len(text) < 40 or bool(SECTION.match(text)))


def _is_table_or_code(text: str) -> bool:
    s = text.strip()
    return bool(
        s.startswith(
            (">>>", "... ", "|", "+-", "$ ", ".. ", "```", "python ", "pip ", "uv ", "git ")
        )
        or re.search(r"\S {2,}\S", s)
        or re.fullmatch(r"[-=~^+*#]{3,}", s)
        or s.endswith("::")
    )


# --------------------------------------------------------------------------------------------------
# 1. docstrings


def _char_col(line: str, byte_col: int) -> int:
    return len(line.encode("utf-8")[:byte_col].decode("utf-8", errors="replace"))


def _field_doc_ids(tree: ast.AST) -> set[int]:
    ids = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef):
            for prev, cur in zip(node.body, node.body[1:], strict=False):
                if isinstance(prev, ast.AnnAssign) and isinstance(cur, ast.Expr):
                    ids.add(id(cur))
    return ids


def _label_doc_ids(tree: ast.AST) -> set[int]:
    """Docstrings whose first paragraph stays as it is: learning/pairs.py labels a dataset with the
    first line of a task's policy_observation docstring."""
    ids = set()
    for node in ast.walk(tree):
        if (
            isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.name == "policy_observation"
        ):
            if node.body and isinstance(node.body[0], ast.Expr):
                ids.add(id(node.body[0]))
    return ids


SECTION = re.compile(
    r"^(Args|Arguments|Attributes|Returns|Yields|Raises|Parameters|Fields|Keys|Note|Notes)( "
    r"\([^)]*\))?:\s*$"
)
ENTRY = re.compile(r"^[*\w`][\w.*`'\[\], |/-]*(\s\([^)]*\))?:(\s|$)")


def wrap_words_joinable(words: list[str], first: int, rest: int) -> list[str]:
    """`wrap_words`, but a line never starts with a word whose first character is not a letter:
    tyro's help (remove_single_line_breaks) keeps a line break before such a line, so the shown text
    would change."""
    lines: list[list[str]] = [[]]
    limit = first
    for word in words:
        cur = lines[-1]
        if not cur or len(" ".join(cur + [word])) <= limit:
            cur.append(word)
            continue
        if word[0].isalpha():
            lines.append([word])
            limit = rest
            continue
        for j in range(len(cur) - 1, 0, -1):
            if cur[j][0].isalpha() and len(" ".join(cur[j:] + [word])) <= rest:
                lines.append(cur[j:] + [word])
                del cur[j:]
                limit = rest
                break
        else:
            cur.append(word)
    return [" ".join(line) for line in lines if line]


def _reflow_doc_body(
    body: str, base: int, open_len: int, width: int, joinable: bool, keep_first: bool = False
) -> str | None:
    """The docstring's text between its quotes, re-flowed; None when nothing changes.

    `joinable`: the docstring may be shown by tyro as a description, which joins single line breaks
    except before a line that starts with something other than a letter: such a line is kept where
    it starts, and no new line starts that way.
    """
    lines = body.split("\n")
    closing_on_last = lines[-1].strip() != "" or len(lines) == 1
    items = []  # (relative indent, stripped text, raw line)
    for i, line in enumerate(lines):
        if i == 0:
            items.append((0, line.strip(), line))
        else:
            stripped = line.lstrip(" ")
            items.append((len(line) - len(stripped) - base, stripped.rstrip(), line))

    def physical_len(i: int) -> int:
        n = len(lines[i]) + (open_len + base if i == 0 else 0)
        if i == len(lines) - 1 and closing_on_last:
            n += 3
        return n

    # paragraphs: [kind, rel indent, hang, [line indices]]; kind "prose", "list" (hanging indent)
    # or "fixed"
    paras: list[list] = []
    in_fence = False
    # inside an Args:/Attributes:/Returns: section, where indented lines are prose too
    section = False
    for i, (rel, text, raw) in enumerate(items):
        last = paras[-1] if paras else None
        if text.startswith("```") or text.startswith("~~~"):
            in_fence = not in_fence
            paras.append(["fixed", rel, 0, [i]])
            continue
        if in_fence or not text or "\t" in raw or rel < 0 or _is_table_or_code(text):
            paras.append(["fixed", rel, 0, [i]])
            continue
        # a section starts at its header, also one that ends a line of prose ("... Attributes:")
        if rel == 0:
            section = bool(SECTION.match(text) or SECTION.match(text.rsplit(". ", 1)[-1]))
        breaks_here = joinable and not text[0].isalpha()
        mark = LIST_MARK.match(text)
        if mark and i > 0:
            paras.append(["list", rel, rel + len(mark.group(0)), [i]])
            continue
        if section and rel > 0 and ENTRY.match(text):
            nxt = items[i + 1] if i + 1 < len(items) else None
            hang = nxt[0] if nxt and nxt[1] and nxt[0] > rel else rel + 4
            paras.append(["list", rel, hang, [i]])
            continue
        if last and not _is_header(items[last[3][-1]][1]):
            if (last[0] == "list" and rel == last[2]) or (last[0] == "prose" and rel == last[1]):
                if not breaks_here:
                    last[3].append(i)
                else:  # tyro keeps this line break: the line starts a paragraph at the same indent
                    paras.append([last[0], rel, rel, [i]])
                continue
        if rel == 0 or section:
            paras.append(["prose", rel, 0, [i]])
        else:
            paras.append(["fixed", rel, 0, [i]])

    out: list = list(lines)
    changed = False
    for kind, rel, hang, idx in paras:
        if keep_first and idx[0] == 0:
            # the first line stays as it is; the rest of its paragraph may be re-flowed
            idx = idx[1:]
        if kind == "fixed" or not idx or not any(physical_len(i) > width for i in idx):
            continue
        words = " ".join(items[i][1] for i in idx).split()
        has_close = idx[-1] == len(lines) - 1 and closing_on_last
        if has_close:
            words[-1] += '"""'
        first_width = width - (base + open_len if idx[0] == 0 else base + rel)
        cont = hang if kind == "list" else rel
        rest_width = width - base - cont
        wrapped = (wrap_words_joinable if joinable else wrap_words)(words, first_width, rest_width)
        if has_close:
            wrapped[-1] = wrapped[-1][:-3]
        new = []
        for j, text in enumerate(wrapped):
            if j == 0:
                lead = (
                    lines[0][: len(lines[0]) - len(lines[0].lstrip())]
                    if idx[0] == 0
                    else " " * (base + rel)
                )
            else:
                lead = " " * (base + cont)
            new.append(lead + text)
        for i in idx:
            out[i] = None
        out[idx[0]] = "\n".join(new)
        changed = True
    if not changed:
        return None
    return "\n".join(x for x in out if x is not None)


def pass_docstrings(source: str, width: int, field_docs: bool) -> str:
    tree = ast.parse(source)
    lines = source.splitlines(keepends=True)
    labels = _label_doc_ids(tree)
    skip = set() if field_docs else _field_doc_ids(tree)
    # docstrings tyro may show as a description: a module's passed as description=__doc__, and a
    # dataclass's
    # (tyro shows a nested dataclass's docstring above its group of flags)
    described = {id(tree.body[0])} if tree.body and "__doc__" in source else set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef) and node.body:
            fields = any(isinstance(stmt, ast.AnnAssign) for stmt in node.body)
            if fields or any("dataclass" in ast.unparse(d) for d in node.decorator_list):
                described.add(id(node.body[0]))
    edits = []
    for node in ast.walk(tree):
        if not (
            isinstance(node, ast.Expr)
            and isinstance(node.value, ast.Constant)
            and isinstance(node.value.value, str)
        ):
            continue
        if id(node) in skip:
            continue
        c = node.value
        start_line = lines[c.lineno - 1]
        col = _char_col(start_line, c.col_offset)
        end_line = lines[c.end_lineno - 1]
        end_col = _char_col(end_line, c.end_col_offset)
        seg_lines = lines[c.lineno - 1 : c.end_lineno]
        if not any(len(line.rstrip("\r\n")) > width for line in seg_lines):
            continue
        if c.lineno == c.end_lineno:
            token = start_line[col:end_col]
        else:
            token = (
                start_line[col:] + "".join(lines[c.lineno : c.end_lineno - 1]) + end_line[:end_col]
            )
        m = re.match(r'^([rRuU]?)("""|\'\'\')', token)
        if not m or not token.endswith(m.group(2)) or len(token) < 6:
            continue  # not one triple-quoted literal (maybe implicitly concatenated)
        prefix, quote = m.group(1), m.group(2)
        body = token[len(prefix) + 3 : -3]
        if quote in body or (
            not prefix.lower().startswith("r") and re.search(r"(?<!\\)(\\\\)*\\\n", body)
        ):
            continue
        base = _char_col(start_line, node.col_offset)
        if col != base:
            continue
        new_body = _reflow_doc_body(
            body, base, len(prefix) + 3, width, id(node) in described, id(node) in labels
        )
        if new_body is None:
            continue
        edits.append((c.lineno, col, c.end_lineno, end_col, prefix + quote + new_body + quote))
    return apply_edits(lines, edits)


def apply_edits(lines: list[str], edits: list[tuple]) -> str:
    """Replace (start row, start col, end row, end col) spans, in characters, with text; rows count
    from 1."""
    lines = list(lines)
    for srow, scol, erow, ecol, text in sorted(edits, reverse=True):
        head = lines[srow - 1][:scol]
        tail = lines[erow - 1][ecol:]
        lines[srow - 1 : erow] = [head + text + tail]
    return "".join(lines)


# --------------------------------------------------------------------------------------------------
# 2. long string literals in code


def _split_points(body: str, is_f: bool, is_raw: bool) -> list[int]:
    """Offsets in `body` right after a run of spaces where the literal may be cut."""
    points = []
    depth = 0
    i = 0
    n = len(body)
    while i < n:
        ch = body[i]
        if ch == "\\" and not is_raw:
            i += 2
            continue
        if ch == "\\" and is_raw:
            i += 2  # a raw literal cannot end in a backslash: never cut right after one
            continue
        if is_f and ch in "{}":
            if i + 1 < n and body[i + 1] == ch and depth == 0:
                i += 2
                continue
            depth += 1 if ch == "{" else -1
            i += 1
            continue
        if ch == " " and depth == 0:
            j = i
            while j < n and body[j] == " ":
                j += 1
            if j < n:
                points.append(j)
            i = j
            continue
        i += 1
    return points


def split_literal(token: str, room: int, force: bool = False) -> list[str] | None:
    """`token` (one single-line literal) cut into pieces of at most `room` columns where it can be;
    None if not."""
    m = re.match(r"^([a-zA-Z]*)(['\"])", token)
    if not m:
        return None
    prefix, quote = m.group(1), m.group(2)
    if token[len(prefix) : len(prefix) + 3] in ('"""', "'''") or not token.endswith(quote):
        return None
    low = prefix.lower()
    body = token[len(prefix) + 1 : -1]
    if "\\N{" in body and "r" not in low:
        return None
    points = _split_points(body, "f" in low, "r" in low)
    inner = room - len(prefix) - 2
    if not points or inner < 20:
        return None
    pieces = []
    start = 0
    while len(body) - start > inner:
        fits = [p for p in points if start < p <= start + inner]
        later = [p for p in points if p > start + inner]
        cut = fits[-1] if fits else (later[0] if later else None)
        if cut is None:
            break
        pieces.append(body[start:cut])
        start = cut
    pieces.append(body[start:])
    if len(pieces) < 2 and force:
        middle = min(points, key=lambda p: abs(p - len(body) / 2))
        pieces = [body[:middle], body[middle:]]
    if len(pieces) < 2:
        return None
    out = []
    for piece in pieces:
        p = prefix
        if "f" in low and "{" not in piece and "}" not in piece:
            p = prefix.replace("f", "").replace("F", "")
        out.append(p + quote + piece + quote)
    return out


def _tokens(source: str) -> list[tokenize.TokenInfo]:
    return list(tokenize.generate_tokens(io.StringIO(source).readline))


def pass_strings(source: str, width: int, doc_rows: set[int]) -> str:
    lines = source.splitlines(keepends=True)
    toks = _tokens(source)
    depth = 0
    edits = []
    for k, tok in enumerate(toks):
        if tok.type == tokenize.OP and tok.string in "([{":
            depth += 1
        elif tok.type == tokenize.OP and tok.string in ")]}":
            depth -= 1
        if tok.type != tokenize.STRING or tok.start[0] != tok.end[0] or tok.start[0] in doc_rows:
            continue
        row = tok.start[0]
        line = lines[row - 1].rstrip("\r\n")
        if len(line) <= width:
            continue
        prev = toks[k - 1] if k else None
        nxt = toks[k + 1] if k + 1 < len(toks) else None
        # a literal glued to a neighbour's prefix or inside a decorator-free context only; skip odd
        # spots
        if (prev is not None and prev.type == tokenize.STRING) or (
            nxt is not None and nxt.type == tokenize.STRING
        ):
            if depth == 0:
                # `("a" "b") "c"` would not parse; inside brackets the pieces just join the run
                continue
        indent = len(line) - len(line.lstrip(" "))
        room = width - indent - 4 * max(depth, 1) - 2
        before, after = line[: tok.start[1]].strip(), line[tok.end[1] :].strip()
        alone = (before == "" or before.endswith(("return", "=", "(", "raise"))) and len(after) <= 3
        pieces = split_literal(tok.string, room, force=alone or tok.end[1] > width)
        if not pieces:
            continue
        pad = " " * (tok.start[1] + (0 if depth else 4))
        joined = ("\n" + pad).join(pieces)
        if depth == 0:
            joined = "(\n" + pad + joined + "\n" + " " * tok.start[1] + ")"
            # a literal right after a keyword such as `assert x,` / `return` / `=` only
            if prev is None or not (
                (
                    prev.type == tokenize.OP
                    and prev.string in ("=", ",", ":", "+=", "->", "==", "!=", "%", "+")
                )
                or (
                    prev.type == tokenize.NAME
                    and prev.string in ("return", "yield", "assert", "raise", "in", "else")
                )
            ):
                continue
        edits.append((row, tok.start[1], row, tok.end[1], joined))
    return apply_edits(lines, edits)


# --------------------------------------------------------------------------------------------------
# 3. trailing comments, 4. full-line comments


def _string_rows(toks: list[tokenize.TokenInfo]) -> set[int]:
    """Rows that start inside a multi-line token, or continue a backslash-continued line."""
    rows = set()
    for tok in toks:
        if tok.start[0] != tok.end[0]:
            rows.update(range(tok.start[0] + 1, tok.end[0] + 1))
    return rows


def pass_trailing_comments(source: str, width: int) -> str:
    lines = source.splitlines(keepends=True)
    toks = _tokens(source)
    inside = _string_rows(toks)
    first_on_row: dict[int, tokenize.TokenInfo] = {}
    for tok in toks:
        if tok.type in (
            tokenize.NL,
            tokenize.NEWLINE,
            tokenize.INDENT,
            tokenize.DEDENT,
            tokenize.ENDMARKER,
        ):
            continue
        first_on_row.setdefault(tok.start[0], tok)
    edits = []
    for tok in toks:
        if tok.type != tokenize.COMMENT:
            continue
        row = tok.start[0]
        line = lines[row - 1].rstrip("\r\n")
        if len(line) <= width or first_on_row.get(row) is tok or row in inside:
            continue
        if PRAGMA.match(tok.string) or re.search(
            r"#\s*(noqa|type:\s*ignore|pragma|pyright:|fmt:)", tok.string
        ):
            # a pragma must stay on the statement's first line (an opened import keeps it)
            # when the formatter splits the import
            code = line[: tok.start[1]].rstrip()
            found = re.fullmatch(r"(\s*)from (\S+) import ([\w, ]+)", code)
            reason = re.fullmatch(
                r"(#\s*(?:type:\s*ignore|pyright:\s*ignore|noqa)\S*)\s+(#.*)", tok.string
            )
            if (
                reason
                and not (row > 1 and lines[row - 2].rstrip("\r\n").endswith("\\"))
                and row not in inside
            ):
                # `code  # type: ignore[x]  # why`: the why goes above, the pragma stays on the line
                indent = len(code) - len(code.lstrip(" "))
                newline = lines[row - 1][len(lines[row - 1].rstrip("\r\n")) :]
                edits.append(
                    (
                        row,
                        " " * indent
                        + reason.group(2)
                        + newline
                        + code
                        + "  "
                        + reason.group(1)
                        + newline,
                    )
                )
                continue
            if found and tok.string.startswith("# noqa") and first_on_row.get(row).string == "from":
                pad, module, names = found.groups()
                body = "".join(f"{pad}    {name.strip()},\n" for name in names.split(","))
                edits.append((row, f"{pad}from {module} import (  {tok.string}\n{body}{pad})\n"))
            continue
        if row > 1 and lines[row - 2].rstrip("\r\n").endswith("\\"):
            continue
        code = line[: tok.start[1]].rstrip()
        indent = len(code) - len(code.lstrip(" "))
        newline = lines[row - 1][len(lines[row - 1].rstrip("\r\n")) :]
        edits.append((row, " " * indent + tok.string + newline + code + newline))
    lines = list(lines)
    for row, text in sorted(edits, reverse=True):
        lines[row - 1] = text
    return "".join(lines)


def pass_comments(source: str, width: int) -> str:
    lines = source.splitlines(keepends=True)
    toks = _tokens(source)
    comment_rows: dict[int, int] = {}  # row -> column of a comment that is alone on its line
    first_on_row: dict[int, tokenize.TokenInfo] = {}
    for tok in toks:
        if tok.type in (
            tokenize.NL,
            tokenize.NEWLINE,
            tokenize.INDENT,
            tokenize.DEDENT,
            tokenize.ENDMARKER,
        ):
            continue
        first_on_row.setdefault(tok.start[0], tok)
    for row, tok in first_on_row.items():
        if tok.type == tokenize.COMMENT:
            comment_rows[row] = tok.start[1]
    out = list(lines)
    row = 1
    n = len(lines)
    while row <= n:
        if row not in comment_rows:
            row += 1
            continue
        col = comment_rows[row]
        block = [row]
        while row + len(block) in comment_rows and comment_rows[row + len(block)] == col:
            block.append(row + len(block))
        _reflow_comment_block(out, block, col, width)
        row += len(block)
    return "".join(x for x in out if x is not None)


def _reflow_comment_block(out: list, block: list[int], col: int, width: int) -> None:
    items = []
    for r in block:
        raw = out[r - 1]
        newline = raw[len(raw.rstrip("\r\n")) :]
        text = raw.rstrip("\r\n")[col:]
        items.append((r, text, newline))
    paras: list[list] = []  # [kind, hang, [indices]]
    for i, (_r, text, _) in enumerate(items):
        body = text[1:]
        if body.startswith(" "):
            body = body[1:]
        ruler = re.fullmatch(r"(#.*?)(([-=~*#])\3{3,})", text)
        if (
            ruler
            or PRAGMA.match(text)
            or not body.strip()
            or text.startswith("#:")
            or text.startswith("##")
        ):
            paras.append(["fixed", 0, [i]])
            continue
        lead = len(body) - len(body.lstrip(" "))
        stripped = body.strip()
        if _is_table_or_code(stripped):
            paras.append(["fixed", 0, [i]])
            continue
        mark = LIST_MARK.match(body) if lead == 0 else None
        last = paras[-1] if paras else None
        if mark:
            paras.append(["list", len(mark.group(0)), [i]])
            continue
        if last and last[0] == "list" and lead == last[1]:
            last[2].append(i)
            continue
        if lead == 0:
            # tyro reads a dataclass field's comment as its help and keeps a break before a
            # non-letter: so do we
            joins = stripped[0].isalpha()
            if (
                joins
                and last
                and last[0] == "prose"
                and not _is_header(items[last[2][-1]][1][1:].strip())
            ):
                last[2].append(i)
            else:
                paras.append(["prose", 0, [i]])
            continue
        paras.append(["fixed", 0, [i]])
    for kind, hang, idx in paras:
        rule = re.fullmatch(r"(#.*?)(([-=~*#])\3{3,})", items[idx[0]][1])
        if kind == "fixed" and len(idx) == 1 and rule and col + len(items[idx[0]][1]) > width:
            # a ruler comment (# ---- name ----): its tail is cut to fit
            r, text, newline = items[idx[0]]
            out[r - 1] = " " * col + text[: width - col] + newline
            continue
        if kind == "fixed" or not any(col + len(items[i][1]) > width for i in idx):
            continue
        words = []
        for i in idx:
            words += items[i][1][1:].split()
        room = width - col - 2
        wrapped = wrap_words_joinable(words, room, room - hang)
        pad = " " * col
        new = [pad + "# " + wrapped[0]] + [pad + "# " + " " * hang + w for w in wrapped[1:]]
        newline = items[idx[-1]][2] or "\n"
        for i in idx:
            out[items[i][0] - 1] = None
        out[items[idx[0]][0] - 1] = newline.join(new) + newline


# --------------------------------------------------------------------------------------------------


def doc_string_rows(source: str) -> set[int]:
    rows = set()
    for node in ast.walk(ast.parse(source)):
        if (
            isinstance(node, ast.Expr)
            and isinstance(node.value, ast.Constant)
            and isinstance(node.value.value, str)
        ):
            rows.update(range(node.lineno, node.end_lineno + 1))
    return rows


def rewrap(source: str, width: int, field_docs: bool, filename: str) -> tuple[str, list[str]]:
    notes = []
    passes = [
        ("docstrings", lambda s: pass_docstrings(s, width, field_docs)),
        ("strings", lambda s: pass_strings(s, width, doc_string_rows(s))),
        ("trailing comments", lambda s: pass_trailing_comments(s, width)),
        ("comments", lambda s: pass_comments(s, width)),
    ]
    for name, fn in passes:
        try:
            new = fn(source)
        except (SyntaxError, tokenize.TokenError, ValueError, IndexError) as err:
            notes.append(f"{filename}: {name} pass skipped ({type(err).__name__}: {err})")
            continue
        if new == source:
            continue
        problem = compare(source, new, filename)
        if problem:
            notes.append(f"{filename}: {name} pass dropped ({problem})")
            continue
        source = new
    return source, notes


def python_files(paths: list[str]) -> list[str]:
    files = []
    for path in paths:
        if os.path.isfile(path):
            files.append(path)
            continue
        for root, dirs, names in os.walk(path):
            dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS and not d.startswith("."))
            files += [os.path.join(root, name) for name in sorted(names) if name.endswith(".py")]
    return files


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("paths", nargs="+")
    parser.add_argument("--width", type=int, default=100)
    parser.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 if a file would change"
    )
    parser.add_argument(
        "--field-docs", action="store_true", help="rewrap dataclass field docstrings too"
    )
    parser.add_argument("--verbose", action="store_true")
    args = parser.parse_args()
    started = time.perf_counter()
    changed = 0
    files = python_files(args.paths)
    for path in files:
        with open(path, encoding="utf-8", newline="") as f:
            before = f.read()
        after, notes = rewrap(before, args.width, args.field_docs, path)
        for note in notes:
            print(note, file=sys.stderr)
        if after == before:
            continue
        changed += 1
        if args.verbose:
            print(f"rewrapped {path}")
        if not args.check:
            with open(path, "w", encoding="utf-8", newline="") as f:
                f.write(after)
    verb = "would rewrap" if args.check else "rewrapped"
    print(f"{verb} {changed} of {len(files)} files in {time.perf_counter() - started:.1f} s")
    return 1 if args.check and changed else 0


if __name__ == "__main__":
    sys.exit(main())
