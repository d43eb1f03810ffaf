"""The text of a model file to its table of sections: TOML or JSON, with a syntax error naming
its line and column (and, in JSON, a key given twice)."""

from __future__ import annotations

import json
import re
import tomllib

from ..errors import ModelError


def _parse_toml(text: str, file: str) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = str(e)
        m = re.search(r"\s*\(at line (\d+), column (\d+)\)", msg)
        if m is None:
            raise ModelError(f"invalid TOML: {msg}", file=file, field="",
                             fix="Check the end of the file (unclosed brackets or quotes)") from None
        line = int(m.group(1))
        src = text.splitlines()[line - 1].strip() if line <= len(text.splitlines()) else ""
        raise ModelError(f"invalid TOML: {msg[:m.start()]} (column {m.group(2)}: {src!r})",
                         file=file, field=f"line {line}",
                         fix="Write key = value with quoted strings, [table] and [[array of tables]] "
                             "headers, and each table declared once") from None


def _parse_json(text: str, file: str) -> dict:
    def no_duplicates(pairs):
        keys = [k for k, _ in pairs]
        dup = next((k for k in keys if keys.count(k) > 1), None)
        if dup is not None:
            raise ModelError(f"key '{dup}' appears twice in one JSON object", file=file,
                             fix="Keep one of the two")
        return dict(pairs)

    try:
        data = json.loads(text, object_pairs_hook=no_duplicates)
    except json.JSONDecodeError as e:
        src = text.splitlines()[e.lineno - 1].strip() if e.lineno <= len(text.splitlines()) else ""
        raise ModelError(f"invalid JSON: {e.msg} (column {e.colno}: {src!r})", file=file,
                         field=f"line {e.lineno}",
                         fix="Check commas, brackets and double quotes near that line") from None
    if not isinstance(data, dict):
        raise ModelError("the top level must be a JSON object", file=file,
                         fix='Write {"bodies": [...], "joints": [...], ...}')
    return data
