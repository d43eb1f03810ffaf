"""The files of a design study: its chunks folder, the files an earlier run wrote, a designs CSV
and a finished sweep's folder, each read or removed so that nothing the study did not write is
touched and a damaged or foreign file is refused with a message naming it.

- ``OUTDIR/chunks/``: ``study.json`` (the study's fingerprint, and whether the sweep made the
  folder) and ``chunk-<k>.parquet``; a sweep removes only those, and the folder only when it
  made it and nothing else is left in it. A ``study.json`` that is not a sweep's, or chunk
  files without one, are another program's: refused, never overwritten.
- A command's earlier outputs: its manifest (``summary.json`` of a sweep, ``optimize.json``)
  lists the files it wrote (``files``), and only those are removed when a new run does not
  write them again (a report of an earlier ``--report`` run); a file of the same family that
  no run listed is the user's.
"""

from __future__ import annotations

import io
import json
import os
import re
from pathlib import Path

import numpy as np

from ..errors import ModelError
from ..outputs import owned_before  # noqa: F401  (the studies' manifests: summary, optimize.json)


class MissingExtra(ModelError, ImportError):
    """A study without the optional packages it needs (pandas, pyarrow): exit status 2, one
    line saying how to install them, no traceback (an ``ImportError`` too, for Python
    callers)."""


INSTALL = ("Install the extra: pip install 'linkdyn[parquet]' (from a checkout: "
           ".venv/bin/pip install -e '.[parquet]')")


def _pandas():
    """pandas, or a :class:`MissingExtra` that says how to install it."""
    try:
        import pandas as pd
    except ImportError:
        raise MissingExtra("sweeps need pandas (their table of designs is a DataFrame)",
                           field="pandas", fix=INSTALL) from None
    return pd


def need_parquet(command: str) -> None:
    """Raise :class:`MissingExtra` before any work unless pandas and pyarrow (the parquet files
    ``command`` writes and reads) are importable."""
    missing = []
    for name in ("pandas", "pyarrow"):
        try:
            __import__(name)
        except ImportError:
            missing.append(name)
    if missing:
        raise MissingExtra(f"linkdyn {command} needs {' and '.join(missing)}, which "
                           f"{'is' if len(missing) == 1 else 'are'} not installed",
                           field=missing[0], fix=INSTALL)


CHUNKS = "chunks"
STATE = "study.json"
# a chunk, or a worker's temporary file of one (killed before its atomic rename)
CHUNK_FILE = re.compile(r"chunk-\d{6}\.parquet(\.tmp\d+)?\Z")
_FINGERPRINT = re.compile(r"[0-9a-f]{64}\Z")
#: Largest designs CSV read, bytes (about 4 million designs of two parameters).
MAX_DESIGNS_CSV_BYTES = 100_000_000
#: Most parameters (columns) of a designs CSV.
MAX_PARAMETERS = 1000


def chunk_path(outdir: Path, k: int) -> Path:
    return Path(outdir) / CHUNKS / f"chunk-{k:06d}.parquet"


def _foreign(path: Path, why: str) -> ModelError:
    return ModelError(f"'{path}' {why}", field="-o",
                      fix="Move or rename it, or give another -o folder")


def read_state(outdir: Path) -> dict | None:
    """The state of the sweep whose chunks are in ``outdir/chunks`` (None: no sweep's).

    Raises
    ------
    ModelError
        ``chunks`` or its ``study.json`` is not what a sweep writes (a file where the folder
        is, a folder or junk for the state), or chunk files lie there without a state.
    """
    folder = Path(outdir) / CHUNKS
    if not os.path.lexists(folder):
        return None
    if not folder.is_dir():
        raise _foreign(folder, "is not a folder; a sweep keeps its chunks there")
    state = folder / STATE
    if not os.path.lexists(state):
        stray = sorted(e.name for e in os.scandir(folder) if CHUNK_FILE.match(e.name))
        if stray:
            raise _foreign(folder / stray[0], f"is not a chunk of a sweep: no {STATE} beside it "
                                              "names the study it belongs to")
        return None
    try:
        from ..io.files import read_text
        data = json.loads(read_text(state, 1_000_000))
    except (OSError, ValueError):   # a folder, a device, junk, not UTF-8 (FileRefused too)
        data = None
    if not (isinstance(data, dict) and isinstance(data.get("fingerprint"), str)
            and _FINGERPRINT.match(data["fingerprint"])):
        raise _foreign(state, "is not the state of a linkdyn sweep")
    return data


def prepare_chunks(outdir: Path, fingerprint: str, designs: int, chunk: int,
                   resume: bool) -> list[int]:
    """Make ``outdir/chunks`` ready for a sweep: the chunks that can be reused (resume).

    Without ``resume`` the files of an earlier sweep there are removed; with it, a sweep of
    another study is refused. Other files are left alone.

    Returns
    -------
    list of int
        The chunk numbers whose files exist (resume only); read them with :func:`read_chunk`.
    """
    out = Path(outdir)
    folder = out / CHUNKS
    old = read_state(out)
    created = old.get("created", False) if old else not os.path.lexists(folder)
    if old is not None and resume and old["fingerprint"] != fingerprint:
        raise ModelError("the directory holds chunks of a different study", field=str(out),
                         fix="Give the same model, --vary ranges, method, designs and samples "
                             "to resume, or another -o directory")
    if old is not None and not resume:
        remove_chunk_files(out)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / STATE).write_text(json.dumps({"fingerprint": fingerprint, "designs": designs,
                                            "chunk": chunk, "created": bool(created)}))
    if not resume:
        return []
    return [int(e.name[6:12]) for e in os.scandir(folder)
            if CHUNK_FILE.match(e.name) and e.name.endswith(".parquet")
            and e.is_file(follow_symlinks=False)]


def read_chunk(outdir: Path, k: int, names, size: int) -> dict | None:
    """Chunk ``k``'s columns, or None when its file is damaged (it is then computed again):
    columns ``names`` of ``size`` rows, ``valid`` boolean."""

    try:
        df = _pandas().read_parquet(chunk_path(outdir, k))
    except Exception:   # truncated or junk: whatever pyarrow raises, the chunk is redone
        return None
    if list(df.columns) != list(names) or len(df) != size or df["valid"].dtype != bool:
        return None
    return {c: df[c].to_numpy() for c in df.columns}


def remove_chunk_files(outdir: Path) -> None:
    """Remove the chunk files in ``outdir/chunks`` (and their temporary files)."""
    folder = Path(outdir) / CHUNKS
    for e in os.scandir(folder):
        if CHUNK_FILE.match(e.name) and e.is_file(follow_symlinks=False):
            os.unlink(e.path)


def remove_chunks(outdir: Path) -> None:
    """Remove what a sweep wrote in ``outdir/chunks``: its chunk files, its state, and the
    folder when the sweep made it and nothing else is in it. Nothing when no sweep's state is
    there."""
    folder = Path(outdir) / CHUNKS
    try:
        state = read_state(outdir)
    except ModelError:
        return
    if state is None:
        return
    remove_chunk_files(outdir)
    os.unlink(folder / STATE)
    if state.get("created"):
        try:
            folder.rmdir()
        except OSError:   # the user put files there meanwhile
            pass


def read_designs(path) -> tuple[np.ndarray, list[str]]:
    """Designs of a CSV file: (values (D, P), paths), in the file's units.

    The file must be a regular file of at most :data:`MAX_DESIGNS_CSV_BYTES` bytes (a FIFO or
    a device is refused at once) with at most :data:`MAX_PARAMETERS` columns.
    """
    from ..io.files import FileRefused, read_text

    def fail(message, fix):
        return ModelError(message, file=os.fspath(path), field="--designs-csv", fix=fix)

    try:
        text = read_text(path, MAX_DESIGNS_CSV_BYTES)
    except FileNotFoundError:
        raise fail("file not found", "Check the path") from None
    except FileRefused as e:
        raise fail(f"the designs file {e}", f"Give a CSV file of at most "
                   f"{MAX_DESIGNS_CSV_BYTES:,} bytes, or split the designs into several "
                   "sweeps") from None
    except (OSError, UnicodeDecodeError) as e:
        raise fail(f"cannot read the file ({e})", "Give a readable UTF-8 CSV file") from None
    header = text.split("\n", 1)[0]
    if header.count(",") >= MAX_PARAMETERS:
        raise fail(f"the header has {header.count(',') + 1:,} columns, more than the limit of "
                   f"{MAX_PARAMETERS}", "Give one column per design parameter")
    try:
        df = _pandas().read_csv(io.StringIO(text))
    except Exception as e:  # pandas' parser errors
        raise fail(f"cannot read the designs ({str(e)[:200]})",
                   "Give a CSV file: a header of field paths, one row per design") from None
    if df.empty or not len(df.columns):
        raise fail("no designs in the file", "Give a header of field paths and one row per "
                                             "design")
    try:
        values = df.to_numpy(float)
    except (TypeError, ValueError):
        raise fail("every value must be a number", "Give numbers in the file's units") from None
    if not np.all(np.isfinite(values)):
        r = int(np.argmax(~np.all(np.isfinite(values), axis=1)))
        raise fail(f"row {r + 1} has a missing or non-finite value",
                   "Give a number in every column of every row")
    return values, [str(c).strip() for c in df.columns]


def read_sweep(folder, option: str = "--sweep"):
    """A finished sweep's folder: ``(summary, designs)``, its ``summary.json`` (a dict with the
    model file, the parameters and the metrics) and ``designs.parquet`` (a DataFrame with
    ``design``, ``valid``, one numeric column per parameter and per metric).

    Raises
    ------
    ModelError
        Naming ``option`` and the file: a file missing, not readable, not UTF-8 or not JSON, or
        not what a sweep writes (a key, a column or a type missing).
    """
    from ..io.files import read_text

    folder = Path(folder)
    spec, table = folder / "summary.json", folder / "designs.parquet"
    if not spec.is_file() or not table.is_file():
        raise ModelError(f"{folder} holds no finished sweep (summary.json and designs.parquet)",
                         field=option, fix="Give the -o folder of a finished linkdyn sweep")

    def damaged(path, why):
        return ModelError(f"{path}: {why}", field=option,
                          fix="Give the -o folder of a finished linkdyn sweep, or run the "
                              "sweep again")

    try:
        info = json.loads(read_text(spec))
    except (OSError, ValueError) as e:   # not UTF-8, junk, truncated, too large
        raise damaged(spec, f"cannot read the sweep's summary ({str(e)[:120]})") from None
    params = info.get("parameters") if isinstance(info, dict) else None
    if not (isinstance(info, dict) and isinstance(info.get("model"), str) and info["model"]
            and isinstance(params, list) and params
            and all(isinstance(p, dict) and isinstance(p.get("path"), str) for p in params)
            and isinstance(info.get("metrics"), dict)):
        raise damaged(spec, "not a sweep's summary (it needs model, parameters with their "
                            "paths, and metrics)")
    try:
        df = _pandas().read_parquet(table)
    except Exception as e:   # truncated or junk: whatever pyarrow raises
        raise damaged(table, f"cannot read the table of designs ({str(e)[:120]})") from None
    paths = [p["path"] for p in params]
    missing = [c for c in ["design", "valid", *paths] if c not in df.columns]
    if missing:
        raise damaged(table, "no column " + ", ".join(repr(c) for c in missing))
    types = _pandas().api.types
    numeric = [c for c in [*paths, *(m for m in info["metrics"] if m in df.columns)]
               if not types.is_numeric_dtype(df[c]) or types.is_bool_dtype(df[c])]
    if (numeric or df["valid"].dtype != bool or not types.is_integer_dtype(df["design"])
            or df["design"].isna().any()):
        raise damaged(table, "the columns are not a sweep's (valid must be true/false, design "
                             "a whole number and the parameters and metrics numbers"
                             + (f": {', '.join(map(repr, numeric))}" if numeric else "") + ")")
    return info, df
