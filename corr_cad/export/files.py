"""Writing one file: atomically, deterministically, with the user's umask.

The text writers every exporter and stage uses (JSON, CSV, column-formatted
CSV), the sha256 the output folder's manifest records, and the file-name tag
of a crank angle. The output folder itself (staging, commit, recovery) is
:mod:`corr_cad.run.folder.outputs`; this module knows nothing of it.
"""

from __future__ import annotations

import contextlib
import csv
import errno
import hashlib
import io
import itertools
import json
import math
import os
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

from corr_cad.errors import CorrCadError, ExportError

__all__ = [
    "write_json",
    "write_new_text",
    "writing",
    "write_csv",
    "write_columns",
    "atomic_writer",
    "format_columns",
    "sha256_of",
    "angle_tag",
]


def sha256_of(path: Path, sync: bool = False) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
        if sync:
            os.fsync(f.fileno())
    return h.hexdigest()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _named(exc: OSError, path: Path) -> OSError:
    """``exc`` naming ``path`` if it names no file (library writers often raise so)."""
    if exc.filename or isinstance(exc, CorrCadError):
        return exc
    return OSError(exc.errno, exc.strerror or str(exc), str(path))


@contextlib.contextmanager
def writing(path: Path, suffix: str = ".part") -> Iterator[Path]:
    """Write ``path`` through a temporary beside it, renamed into place on success.

    Yields the temporary's path (``<name><suffix>``) for a library writer
    to write to. On any error the temporary is removed; an ``OSError`` that
    names no file (a full disk inside a library's writer) is raised again
    naming ``path``, so the user learns which file could not be written.
    """
    path = Path(path)
    tmp = path.with_name(path.name + suffix)
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        named = _named(exc, path)
        if named is exc:
            raise
        raise named from exc
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def _write_synced(fd: int, tmp: str, text: str) -> None:
    """Write ``text`` to the open temporary ``fd``, sync it, give it the umask's mode."""
    with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.chmod(tmp, 0o666 & ~_umask())


@contextlib.contextmanager
def atomic_writer(path: Path) -> Iterator:
    """A text file handle whose content replaces ``path`` only when the block ends well.

    What is written goes to disk as it comes (a large CSV is never held whole
    in memory), is synced and gets the umask's mode; on an error the partial
    file is removed, and an ``OSError`` that names no file names ``path``.
    """
    path = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".part")
    except OSError as exc:
        raise _named(exc, path) from exc
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        named = _named(exc, path)
        if named is exc:
            raise
        raise named from exc
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _atomic_text(path: Path, text: str) -> Path:
    with atomic_writer(path) as f:
        f.write(text)
    return Path(path)


def write_new_text(path: Path, text: str) -> Path:
    """Create ``path`` with ``text``, atomically, never replacing anything.

    The text goes to a temporary of a fresh random name beside ``path`` (so
    no file of the user's is ever written over, whatever it is called); it
    is then linked to ``path``, which fails with :class:`FileExistsError`
    if ``path`` exists by then. A file system without hard links gets an
    exclusive create (``O_EXCL``) instead.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".part")
    try:
        _write_synced(fd, tmp, text)
        try:
            os.link(tmp, path, follow_symlinks=False)
        except FileExistsError:
            raise
        except OSError as exc:
            if exc.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV):
                raise
            with open(path, "x", encoding="utf-8", newline="") as out:
                out.write(text)
    finally:
        Path(tmp).unlink(missing_ok=True)
    return path


def write_json(path: Path, data: object) -> Path:
    """Write ``data`` as indented, key-sorted JSON (deterministic).

    NaN and inf are never written (JSON has neither): the inputs that produce
    them are refused up front; should one slip through, this is one
    :class:`ExportError` line naming the file and the value's place.
    """
    try:
        text = json.dumps(data, indent=2, sort_keys=True, allow_nan=False)
    except ValueError as exc:
        where = _non_finite_at(data) or "a value"
        raise ExportError(
            f"{Path(path).name}: {where} is not a finite number (NaN or inf), which JSON cannot "
            "hold; nothing was written"
        ) from exc
    return _atomic_text(path, text + "\n")


def _non_finite_at(data: object, at: str = "") -> str | None:
    """The place (``figures.rigidity.min``) of the first NaN or inf in ``data``."""
    if isinstance(data, float) and not math.isfinite(data):
        return at or "the value"
    items = (
        data.items()
        if isinstance(data, dict)
        else enumerate(data)
        if isinstance(data, (list, tuple))
        else ()
    )
    for k, v in items:
        found = _non_finite_at(v, f"{at}.{k}" if at else str(k))
        if found:
            return found
    return None


def write_csv(path: Path, header: Sequence[str], rows: Iterable[Sequence[object]]) -> Path:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    return _atomic_text(path, buf.getvalue())


def format_columns(columns: Sequence[object], fmts: Sequence[str]) -> str:
    """CSV body (no header) from equal-length columns and ``%``-formats, one per column.

    Vectorised: one ``%`` operation over all rows, in C. The text is the same,
    byte for byte, as formatting each value with ``format(v, spec)`` and
    writing rows with :func:`write_csv` (numbers never need quoting).
    """
    lists = [c.tolist() if hasattr(c, "tolist") else list(c) for c in columns]
    n = len(lists[0]) if lists else 0
    if n == 0:
        return ""
    row = ",".join(fmts) + "\n"
    # chain.from_iterable flattens in C (10-15 % faster than a nested generator).
    return (row * n) % tuple(itertools.chain.from_iterable(zip(*lists, strict=True)))


#: Rows formatted at a time by :func:`write_columns` (about 10 MB of text).
COLUMN_CHUNK_ROWS = 100_000


def write_columns(
    path: Path, header: Sequence[str], columns: Sequence[object], fmts: Sequence[str]
) -> Path:
    """Write a CSV from columns with :func:`format_columns`, ``COLUMN_CHUNK_ROWS`` at a time.

    The bytes are those of formatting every row at once; the memory is that
    of one chunk (a whole-file string of Python floats took 40 bytes a value).
    """
    n = len(columns[0]) if len(columns) else 0
    with atomic_writer(path) as f:
        f.write(",".join(header) + "\n")
        for a in range(0, n, COLUMN_CHUNK_ROWS):
            f.write(format_columns([c[a : a + COLUMN_CHUNK_ROWS] for c in columns], fmts))
    return Path(path)


def angle_tag(angle_deg: float) -> str:
    """File-name tag of a crank angle: 0 -> 000deg, 7.5 -> 007p5deg, -10 -> m010deg."""
    text = f"{abs(angle_deg):07.3f}".rstrip("0").rstrip(".").replace(".", "p")
    return ("m" if angle_deg < 0 else "") + f"{text}deg"
