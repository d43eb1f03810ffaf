"""All-or-nothing output folders for the commands that write files.

Every command that writes results (``analyze``, ``reproduce``, and any new one) goes through
:func:`write_outputs`, so a failed run never leaves a half-written folder and a successful one
never leaves a stale file of an earlier run beside the new ones.

How a new command uses it::

    from linkdyn.outputs import check_outdir, write_outputs

    check_outdir(outdir)                      # early, before the long work: -o is usable
    sol = ...                                 # compute everything; raise on any error
    files = {"designs.parquet": lambda p: table.to_parquet(p),
             "summary.json": lambda p: p.write_text(text)}
    written = write_outputs(outdir, files, owned=("designs.parquet", "summary.json"))

Each value of ``files`` writes one file at the path it is given (inside a temporary folder);
``owned`` lists the names (shell patterns) of an earlier run's files that this run removes when
it does not write them again (``results.csv`` when writing ``results.parquet``, a report of an
earlier ``--report`` run). A command lists the files it wrote in its manifest
(``summary.json``, ``optimize.json``: ``"files"``) and passes :func:`owned_before`, the files of
its family the earlier run's manifest lists: a file of that family that no run of it wrote (the
user's ``report.html``) is never touched, nor is anything else in the folder.
"""

from __future__ import annotations

import fnmatch
import glob
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

from .errors import ModelError

#: Files ``linkdyn analyze`` (and ``simulate``) write: the results in one format, the summary,
#: the report and the static plots.
ANALYSIS_OUTPUTS = ("results.csv", "results.parquet", "summary.json", "report.html",
                    "plot_*.png", "plot_*.svg")


def owned_before(outdir, manifest: str, patterns) -> tuple[str, ...]:
    """The files matching ``patterns`` that the earlier run of a command in ``outdir`` wrote
    (the ``files`` listed by its ``manifest``, e.g. ``summary.json``), as patterns for
    :func:`write_outputs`'s ``owned``: a new run removes those it does not write again, and
    never a file of that family that no run wrote (none when the folder holds no manifest, or
    one that is not the command's)."""
    from .io.files import read_text
    try:
        listed = json.loads(read_text(Path(outdir) / manifest)).get("files", [])
    except (OSError, ValueError, AttributeError):   # absent, not a manifest, not ours
        return ()
    if not isinstance(listed, list):
        return ()
    return tuple(glob.escape(n) for n in listed
                 if isinstance(n, str) and os.path.basename(n) == n
                 and any(fnmatch.fnmatchcase(n, p) for p in patterns))


def _error(outdir, why: str, option: str) -> ModelError:
    return ModelError(f"cannot write the outputs to '{outdir}': {why}", field=option,
                      fix=f"Give {option} a folder you can write to (it is created if missing)")


def check_outdir(outdir, option: str = "-o") -> None:
    """Check, without creating anything, that ``outdir`` can be an output folder.

    It must be a folder or not exist yet; then its nearest existing ancestor must be a folder
    one can write in. Call it before the long work so a bad ``-o`` fails at once.

    Raises
    ------
    ModelError
        Naming ``option`` (exit status 2): the path or one of its ancestors is a file, a
        device (``/dev/null``) or a folder one cannot write in.
    """
    path = Path(os.path.abspath(outdir))
    try:
        for p in (path, *path.parents):
            if not os.path.lexists(p):
                continue
            if not p.is_dir():
                what = "is not a folder" if p == path else f"'{p}' is a file, not a folder"
                raise _error(outdir, what, option)
            if not os.access(p, os.W_OK | os.X_OK):
                raise _error(outdir, f"'{p}' is not writable", option)
            return
    except OSError as err:
        raise _error(outdir, err.strerror or str(err), option) from None


def write_outputs(outdir, files: Mapping[str, Callable[[Path], object]], *,
                  owned: Iterable[str] = ANALYSIS_OUTPUTS, option: str = "-o",
                  progress=None) -> list[Path]:
    """Write every file of ``files`` into ``outdir``, all or nothing.

    The files are written into a temporary folder beside ``outdir`` (inside it when the parent
    is on another file system or not writable), then moved into place only when every writer
    has succeeded: a new ``outdir`` is the renamed temporary folder, an existing one receives
    each file by an atomic replace. Then the files of an earlier run that match ``owned`` and
    were not written now are removed. Nothing else in ``outdir`` is touched; on any failure
    the temporary folder and any folder created for it are removed.

    Parameters
    ----------
    outdir : str or PathLike
        The output folder (created with its parents if missing).
    files : mapping of str to callable
        ``{file name: writer}``; ``writer(path)`` writes that file at ``path``. Names are plain
        file names (no folders).
    owned : iterable of str
        Names or shell patterns of the files this command writes (default: those of
        ``analyze``); stale ones are removed.
    option : str
        The option that named ``outdir``, for messages.
    progress : object with ``step(label)``, optional
        Told before each file is written.

    Returns
    -------
    list of Path
        ``outdir / name`` for every file written, in the order of ``files``.

    Raises
    ------
    ModelError
        ``outdir`` cannot be written (exit status 2, naming ``option``).
    Exception
        Whatever a writer raises, after cleaning up.
    """
    for name in files:
        if not name or os.path.basename(name) != name or name in (".", ".."):
            raise ValueError(f"output names are plain file names, got {name!r}")
    check_outdir(outdir, option)
    out = Path(os.path.abspath(outdir))
    created: list[Path] = []          # folders made here, removed again on failure
    tmp = None
    try:
        try:
            for p in reversed((out.parent, *out.parent.parents)):
                if not os.path.lexists(p):
                    p.mkdir()
                    created.append(p)
            fresh = not os.path.lexists(out)
            tmp = Path(tempfile.mkdtemp(prefix=f".linkdyn-{out.name}-", dir=_tmp_base(out, fresh)))
            os.chmod(tmp, 0o777 & ~_umask())  # as a plain mkdir would (it may become outdir)
        except OSError as err:
            raise _error(outdir, err.strerror or str(err), option) from None
        for name, write in files.items():
            if progress is not None:
                progress.step(f"writing {name}")
            try:
                write(tmp / name)
            except OSError as err:
                raise _error(outdir, f"writing {name}: {err.strerror or err}", option) from None
        try:
            _move_into_place(tmp, out, fresh, list(files))
        except OSError as err:
            raise _error(outdir, err.strerror or str(err), option) from None
        tmp = None
        created.clear()
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        for p in reversed(created):
            try:
                p.rmdir()
            except OSError:
                pass
    _remove_stale(out, files, owned)
    return [Path(outdir) / name for name in files]


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _tmp_base(out: Path, fresh: bool) -> Path:
    """Folder for the temporary folder: beside ``out`` when that is on the same file system
    (so files move by rename), else inside ``out``."""
    if fresh:
        return out.parent
    if (os.access(out.parent, os.W_OK | os.X_OK)
            and os.stat(out.parent).st_dev == os.stat(out).st_dev):
        return out.parent
    return out


def _move_into_place(tmp: Path, out: Path, fresh: bool, names: list[str]) -> None:
    if fresh:
        try:
            os.rename(tmp, out)  # the whole folder appears at once
            return
        except OSError:
            out.mkdir(exist_ok=True)  # created meanwhile: move file by file
    for name in names:
        os.replace(tmp / name, out / name)
    if tmp.parent != out:
        tmp.rmdir()
    else:
        shutil.rmtree(tmp, ignore_errors=True)


def _remove_stale(out: Path, files: Mapping, owned: Iterable[str]) -> None:
    """Remove files of an earlier run (names matching ``owned``) that this run did not write."""
    patterns = tuple(owned)
    try:
        entries = list(os.scandir(out))
    except OSError:
        return
    for e in entries:
        if e.name in files or not any(fnmatch.fnmatchcase(e.name, p) for p in patterns):
            continue
        if e.is_file(follow_symlinks=False) or e.is_symlink():
            try:
                os.unlink(e.path)
            except OSError:
                pass


def check_file(path, option: str = "-o") -> None:
    """Check, without creating anything, that ``path`` can be written as one file: it is not a
    folder, and its folder exists (or can be created) and is writable.

    Raises
    ------
    ModelError
        Naming ``option`` (exit status 2).
    """
    p = Path(os.path.abspath(path))
    if os.path.isdir(p):
        raise ModelError(f"cannot write '{path}': it is a folder", field=option,
                         fix=f"Give {option} a file name")
    if os.path.lexists(p) and not os.access(p, os.W_OK):
        raise ModelError(f"cannot write '{path}': it is not writable", field=option,
                         fix=f"Give {option} a file you can write")
    check_outdir(p.parent, option)


def write_file(path, text: str, option: str = "-o") -> Path:
    """Write ``text`` (UTF-8) to the file ``path``, all or nothing: into a temporary file
    beside it, then renamed over it, so a failure leaves no partial file and any earlier file
    intact. Its folder is created if missing.

    Raises
    ------
    ModelError
        Naming ``option``: the file or its folder cannot be written.
    """
    check_file(path, option)
    p = Path(path)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=f".{p.name}.", suffix=".tmp")
    except OSError as err:
        raise ModelError(f"cannot write '{path}': {err.strerror or err}", field=option,
                         fix=f"Give {option} a file you can write") from None
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, p)
    except BaseException as err:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(err, OSError):
            raise ModelError(f"cannot write '{path}': {err.strerror or err}", field=option,
                             fix=f"Give {option} a file you can write") from None
        raise
    return p
