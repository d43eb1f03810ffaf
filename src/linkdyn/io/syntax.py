"""The text of a model file to its table of sections: TOML or JSON, with a syntax error naming
its line and column (and, in JSON, a key given twice). Nesting deeper than :data:`MAX_NESTING`
and integers too long to convert are errors naming the line, never a ``RecursionError``."""

from __future__ import annotations

import json
import re
import tomllib

from ..errors import ModelError
from .reader import _quote

MAX_NESTING = 64            # levels of tables and arrays in a model file

_NESTING_FIX = (f"A model file nests tables and arrays at most {MAX_NESTING} levels deep "
                "(a few are enough); check the brackets")


def _line_of(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def _excerpt(text: str, line: int) -> str:
    """Line ``line`` (from 1) of ``text``, stripped, quoted and shortened."""
    start = 0
    for _ in range(line - 1):
        start = text.find("\n", start) + 1
        if start == 0:
            return "''"
    end = text.find("\n", start)
    return _quote(text[start:end if end >= 0 else len(text)].strip())


def _too_long_integer(text: str, file: str, error: Exception) -> ModelError:
    """The ModelError for an integer literal beyond Python's conversion limit (4,300 digits)."""
    m = re.search(r"[0-9][0-9_]{4299,}", text)
    line = _line_of(text, m.start()) if m else 0
    start = text.rfind("\n", 0, m.start()) + 1 if m else 0
    key = re.match(r"\s*\"?([A-Za-z0-9_\-]{1,100})\"?\s*[=:]", text[start:start + 200]) if m else None
    return ModelError(f"a number with {len(m.group()) if m else 'too many':,} digits"
                      + (f" (key '{key.group(1)}')" if key else "") + " is too long to read",
                      file=file, field=f"line {line}" if line else "",
                      fix="Write numbers with at most 17 significant digits, e.g. 1.5e3")


def _check_nesting(data, file: str) -> None:
    """Refuse tables and arrays nested deeper than MAX_NESTING (iteratively, naming the path)."""
    stack = [(data, 0)]
    while stack:                                     # fast pass: depths only
        value, depth = stack.pop()
        if depth > MAX_NESTING:
            break
        if isinstance(value, dict):
            stack.extend((v, depth + 1) for v in value.values() if isinstance(v, (dict, list)))
        elif isinstance(value, list):
            stack.extend((v, depth + 1) for v in value if isinstance(v, (dict, list)))
    else:
        return
    stack = [(data, "", 0)]                          # again, naming the path
    while stack:
        value, path, depth = stack.pop()
        if depth > MAX_NESTING:
            raise ModelError(f"tables and arrays nested more than {MAX_NESTING} levels deep",
                             file=file, field=path[:80] + ("..." if len(path) > 80 else ""),
                             fix=_NESTING_FIX)
        if isinstance(value, dict):
            stack.extend((v, f"{path}.{k}" if path else str(k), depth + 1) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, f"{path}[{i}]", depth + 1) for i, v in enumerate(value))


def _parse_toml(text: str, file: str) -> dict:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = str(e)
        m = re.search(r"\s*\(at line (\d+), column (\d+)\)", msg)
        if m is None:
            raise ModelError(f"invalid TOML: {msg[:200]}", file=file, field="",
                             fix="Check the end of the file (unclosed brackets or quotes)") from None
        line = int(m.group(1))
        raise ModelError(f"invalid TOML: {msg[:m.start()]} (column {m.group(2)}: "
                         f"{_excerpt(text, line)})",
                         file=file, field=f"line {line}",
                         fix="Write key = value with quoted strings, [table] and [[array of tables]] "
                             "headers, and each table declared once") from None
    except RecursionError:
        raise ModelError("tables or arrays nested too deeply to read", file=file,
                         fix=_NESTING_FIX) from None
    except ValueError as e:                  # an integer of more than 4,300 digits
        raise _too_long_integer(text, file, e) from None
    _check_nesting(data, file)
    return data


def _parse_json(text: str, file: str) -> dict:
    def no_duplicates(pairs):
        seen = set()
        for k, _ in pairs:
            if k in seen:
                raise ModelError(f"key {_quote(k)} appears twice in one JSON object", file=file,
                                 fix="Keep one of the two")
            seen.add(k)
        return dict(pairs)

    try:
        data = json.loads(text, object_pairs_hook=no_duplicates)
    except json.JSONDecodeError as e:
        raise ModelError(f"invalid JSON: {e.msg} (column {e.colno}: {_excerpt(text, e.lineno)})",
                         file=file, field=f"line {e.lineno}",
                         fix="Check commas, brackets and double quotes near that line") from None
    except RecursionError:
        raise ModelError("objects or arrays nested too deeply to read", file=file,
                         fix=_NESTING_FIX) from None
    except ValueError as e:                  # an integer of more than 4,300 digits
        raise _too_long_integer(text, file, e) from None
    if not isinstance(data, dict):
        raise ModelError("the top level must be a JSON object", file=file,
                         fix='Write {"bodies": [...], "joints": [...], ...}')
    _check_nesting(data, file)
    return data
