"""Writing results atomically.

A run writes into a staging folder beside the target and swaps it in only
when everything has been written and checked, so a failed or interrupted run
leaves the previous outputs as they were.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path

__all__ = ["StagingDir", "write_json", "write_csv", "write_columns", "format_columns", "sha256_of"]


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _atomic_text(path: Path, text: str) -> Path:
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".part")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(text)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_json(path: Path, data: object) -> Path:
    """Write ``data`` as indented, key-sorted JSON (deterministic)."""
    return _atomic_text(path, json.dumps(data, indent=2, sort_keys=True, allow_nan=False) + "\n")


def write_csv(path: Path, header: Sequence[str], rows: Iterable[Sequence[object]]) -> Path:
    import io

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
    return (row * n) % tuple(v for r in zip(*lists, strict=True) for v in r)


def write_columns(
    path: Path, header: Sequence[str], columns: Sequence[object], fmts: Sequence[str]
) -> Path:
    """Write a CSV from columns with :func:`format_columns`."""
    return _atomic_text(path, ",".join(header) + "\n" + format_columns(columns, fmts))


class StagingDir:
    """Context manager: write into a hidden sibling, swap it in on success.

    >>> with StagingDir(Path("outputs/x")) as stage:   # doctest: +SKIP
    ...     (stage / "a.txt").write_text("...")
    """

    def __init__(self, target: Path):
        self.target = Path(target).resolve()
        self.path: Path | None = None

    def __enter__(self) -> Path:
        self.target.parent.mkdir(parents=True, exist_ok=True)
        self.path = Path(
            tempfile.mkdtemp(dir=self.target.parent, prefix=f".{self.target.name}.staging-")
        )
        os.chmod(self.path, 0o777 & ~_umask())
        return self.path

    def __exit__(self, exc_type, exc, tb) -> None:
        assert self.path is not None
        if exc_type is not None:
            shutil.rmtree(self.path, ignore_errors=True)
            return
        old = None
        if self.target.exists():
            old = Path(tempfile.mkdtemp(dir=self.target.parent, prefix=f".{self.target.name}.old-"))
            old.rmdir()
            os.replace(self.target, old)
        try:
            os.replace(self.path, self.target)
        except BaseException:
            if old is not None:
                os.replace(old, self.target)
            shutil.rmtree(self.path, ignore_errors=True)
            raise
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
