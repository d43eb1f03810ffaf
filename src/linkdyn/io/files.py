"""Reading the files a model names (the model file, motion tables): regular files of bounded size
only, checked with ``os.stat`` before opening, so a FIFO, a device such as ``/dev/zero`` or a huge
file is refused at once instead of blocking or filling memory."""

from __future__ import annotations

import os
import stat

MAX_FILE_BYTES = 10_000_000     # largest model file or motion table read

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


class FileRefused(ValueError):
    """A file that is not a regular file of at most :data:`MAX_FILE_BYTES` bytes."""


def _check(mode: int, size: int, limit: int) -> None:
    if not stat.S_ISREG(mode):
        kind = next((name for test, name in _KINDS if test(mode)), "not a regular file")
        raise FileRefused(f"is {kind}, not a regular file; only regular files are read")
    if size > limit:
        raise FileRefused(f"has {size:,} bytes, more than the limit of {limit:,} bytes")


def read_text(path: str | os.PathLike, limit: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text (a BOM is dropped) of a regular file of at most ``limit`` bytes.

    Raises
    ------
    FileNotFoundError, PermissionError, OSError
        As ``open`` does.
    FileRefused
        For a directory, FIFO, device or socket, or a file larger than ``limit`` (checked with
        ``os.stat`` before opening, and again on the opened file, which is opened non-blocking).
    UnicodeDecodeError
        For a file that is not UTF-8.
    """
    st = os.stat(path)
    _check(st.st_mode, st.st_size, limit)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    with os.fdopen(os.open(path, flags), "rb") as fh:
        st = os.fstat(fh.fileno())                       # the file opened may differ from path's
        _check(st.st_mode, st.st_size, limit)
        data = fh.read(limit + 1)
    _check(stat.S_IFREG, len(data), limit)                # it grew since
    return data.decode("utf-8-sig")
