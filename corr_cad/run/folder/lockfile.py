"""The lock of an output folder: ``<out>/.corr-cad.lock``, one run at a time.

A run holds an exclusive ``flock`` on the lock file, a file that exists only
while the run writes. The file is created exclusively (``O_CREAT |
O_EXCL``) and marked ``corr-cad lock``; a file already at the path is used
only if it is corr-cad's (one name, the mark: left by a killed run).
Anything else is refused in one line naming it, and is never written into
nor removed. Used by :class:`corr_cad.run.folder.outputs.StagingDir`.
"""

from __future__ import annotations

import errno
import fcntl
import os
import stat
import time
from pathlib import Path

from corr_cad.errors import OutputError

__all__ = ["LOCK_NAME", "LOCK_MARK", "LOCK_WAIT_S", "lock", "unlock", "lock_wait_s"]

LOCK_NAME = ".corr-cad.lock"
#: The lock file's content: a file of that name with other content is the user's.
LOCK_MARK = b"corr-cad lock\n"
#: How long a run waits for another run into the same folder before refusing
#: (environment variable ``CORR_CAD_LOCK_WAIT_S`` overrides it, 0..3600 s).
LOCK_WAIT_S = 10.0


def lock_wait_s() -> float:
    raw = os.environ.get("CORR_CAD_LOCK_WAIT_S")
    try:
        value = float(raw) if raw is not None else LOCK_WAIT_S
    except ValueError:
        raise OutputError(
            f"CORR_CAD_LOCK_WAIT_S = {raw!r}: must be a number of seconds in 0..3600"
        ) from None
    if not 0 <= value <= 3600:
        raise OutputError(f"CORR_CAD_LOCK_WAIT_S = {raw!r}: allowed range is 0..3600 s")
    return value


def _regular(p: Path) -> bool:
    return not p.is_symlink() and p.is_file()


#: How long an empty lock file may wait for its creator's mark before it is
#: taken for a file of the user's (the creator writes it microseconds after
#: creating the file; this only bounds a stalled or killed creator).
EMPTY_LOCK_GRACE_S = 2.0


def _not_ours(path: Path, what: str) -> OutputError:
    return OutputError(
        f"{path}: is not corr-cad's lock file ({what}); corr-cad neither writes into nor "
        "removes it - move it away or choose another --out"
    )


def lock(folder: Path, wait_s: float) -> tuple[int, Path]:
    """Hold an exclusive flock on ``<folder>/.corr-cad.lock`` (waits up to ``wait_s``).

    The lock file is created exclusively (``O_CREAT | O_EXCL``) and marked
    ``corr-cad lock``; it is removed when the run ends, and a waiting run
    that then holds a lock on the removed file sees another inode at the
    path and starts over. A file found at the path is used only if it is
    corr-cad's: a regular file with one link (never a hard link to a file of
    the user's) holding the mark (one a killed run left). Anything else is
    refused, never written into nor removed.
    """
    path = folder / LOCK_NAME
    deadline = time.monotonic() + wait_s
    empty_since: float | None = None
    flags = os.O_RDWR | os.O_NOFOLLOW | os.O_CLOEXEC
    while True:
        if os.path.lexists(path) and not _regular(path):
            raise _not_ours(path, "a symlink or not a regular file")
        try:
            fd = os.open(path, flags | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            fd = None
        except OSError as exc:
            raise OutputError(f"{path}: cannot open the lock file ({exc.strerror})") from exc
        if fd is not None:  # ours: lock it and mark it
            fcntl.flock(fd, fcntl.LOCK_EX)  # only a run reading it holds it, for an instant
            try:
                os.pwrite(fd, LOCK_MARK, 0)
            except OSError as exc:  # a full disk: leave no empty lock file behind
                unlock(fd, path)
                raise OutputError(
                    f"{path}: {exc.strerror or exc} (writing the lock file); nothing was "
                    "left behind"
                ) from exc
            return fd, path
        try:
            fd = os.open(path, flags)
        except FileNotFoundError:
            continue  # its run removed it meanwhile: create it
        except OSError as exc:
            raise OutputError(f"{path}: cannot open the lock file ({exc.strerror})") from exc
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
            os.close(fd)
            kind = "not a regular file" if not stat.S_ISREG(st.st_mode) else "a hard link"
            raise _not_ours(path, f"{kind}, {st.st_nlink} names")
        if not _flock_until(fd, deadline):
            os.close(fd)
            raise OutputError(
                f"--out {str(folder)!r}: another corr-cad run is writing into this folder "
                f"(waited {wait_s:g} s); try again when it has finished"
            )
        try:
            same = os.stat(path, follow_symlinks=False).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        content = os.pread(fd, 64, 0) if same else b""
        if same and content == LOCK_MARK:  # left by a killed run: corr-cad's own
            return fd, path
        os.close(fd)
        if not same:
            continue  # the holder removed it as we waited: lock the new one
        if content:
            raise _not_ours(path, "it holds other content")
        now = time.monotonic()
        empty_since = now if empty_since is None else empty_since
        if now - empty_since > EMPTY_LOCK_GRACE_S:
            raise _not_ours(path, "an empty file")
        time.sleep(0.05)  # a run that has just created it writes its mark now


def _flock_until(fd: int, deadline: float) -> bool:
    """Take an exclusive flock on ``fd``, polling until ``deadline``; False if not taken."""
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except OSError as exc:
            if exc.errno not in (errno.EAGAIN, errno.EACCES):
                raise
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.05)


def unlock(fd: int, path: Path) -> None:
    try:
        if os.stat(path, follow_symlinks=False).st_ino == os.fstat(fd).st_ino:
            os.unlink(path)
    except FileNotFoundError:
        pass
    finally:
        os.close(fd)  # closing the descriptor releases the flock
