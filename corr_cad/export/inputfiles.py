"""Reading input files (scenes, measured profiles) safely.

Only regular files of a bounded size are read; everything else gets one
line naming the file and why.
"""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path

from corr_cad.bounds import show
from corr_cad.errors import SceneError

__all__ = ["read_regular_file", "check_regular_file", "first_control_byte", "quotable"]

#: Bytes no text file holds: C0 controls but tab, line feed and carriage return; DEL.
_CONTROL = re.compile(rb"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")


def first_control_byte(path: Path, block: int = 4 << 20) -> tuple[int, int] | None:
    """``(byte offset, line)`` of the first control or NUL byte of a text file, or None.

    Read ``block`` bytes at a time (about 0.1 s for 100 MB): a file of environment
    variables (NUL-separated), terminal escapes or a binary file is named by where
    it goes wrong, and nothing of it is quoted.
    """
    offset, line = 0, 1
    with open(path, "rb") as fh:
        while chunk := fh.read(block):
            m = _CONTROL.search(chunk)
            if m:
                return offset + m.start(), line + chunk.count(b"\n", 0, m.start())
            line += chunk.count(b"\n")
            offset += len(chunk)
    return None


def quotable(text: str) -> bool:
    """Whether a message (a library's, which may quote the file it read) may be shown:
    printable, and no escaped bytes (``\\x1b``, ``\\u0000``) in it."""
    return text.isprintable() and not re.search(
        r"\\(x[0-9a-fA-F]{2}|u[0-9a-fA-F]{4}|[0abefnrtv])", text
    )


def check_regular_file(path: Path, what: str, max_bytes: int, error=SceneError) -> int:
    """The size of ``path`` if it is a regular file of at most ``max_bytes`` (not opened).

    ``os.stat`` only: a FIFO, a device or a folder is refused without being
    opened (opening a FIFO would block, /dev/zero never ends).
    """
    shown = show(str(path), 120)
    if "\0" in str(path):  # os.stat raises ValueError, not OSError, on it
        raise error(f"{what} {shown} contains a NUL character; no file can have that name")
    try:
        st = os.stat(path)
    except FileNotFoundError as exc:
        raise error(f"{what} {shown} does not exist") from exc
    except OSError as exc:
        raise error(f"{what} {shown} cannot be read: {exc.strerror or exc}") from exc
    if stat.S_ISDIR(st.st_mode):
        raise error(f"{what} {shown} is a folder, not a file")
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{what} {shown} is not a regular file (a pipe, device or socket)")
    if st.st_size > max_bytes:
        raise error(
            f"{what} {shown} has {st.st_size} bytes; at most {max_bytes} "
            f"({max_bytes // (1024 * 1024)} MB) are read"
        )
    return st.st_size


def read_regular_file(path: Path, what: str, max_bytes: int, error=SceneError) -> bytes:
    """The bytes of ``path`` if it is a regular file of at most ``max_bytes``.

    :func:`check_regular_file` comes first, so nothing but a regular file is opened.
    """
    shown = show(str(path), 120)
    check_regular_file(path, what, max_bytes, error)
    try:
        with open(path, "rb") as fh:
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise error(f"{what} {shown} cannot be read: {exc.strerror or exc}") from exc
    if len(data) > max_bytes:  # it grew since the stat
        raise error(f"{what} {shown} has more than {max_bytes} bytes")
    return data
