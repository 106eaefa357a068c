"""Reading measured profiles (CSV ``x,y`` mm, or a DXF contour); the comparison DXF."""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely

from corr_cad.bounds import show
from corr_cad.errors import ProfileError
from corr_cad.export import dxf
from corr_cad.export.measured_mesh import is_mesh, read_mesh_profile
from corr_cad.geometry.profile import ProfileCurve
from corr_cad.geometry.sampling import approximate

__all__ = [
    "read_measured_points",
    "read_measured",
    "MeasuredRead",
    "csv_points_kept",
    "MAX_MEASURED_POINTS",
    "write_deviation_dxf",
    "MEASURED_LAYERS",
    "MAX_MEASURED_BYTES",
    "INSUNITS_MM",
]

MEASURED_LAYERS = ("WORKING_PROFILE", "MEASURED_PROFILE", "DEVIATION_EXAGGERATED")


#: Largest measured-profile file read, bytes.
MAX_MEASURED_BYTES = 200 * 1024 * 1024

#: DXF ``$INSUNITS`` code -> millimetres per drawing unit (0 = unitless, read as mm).
INSUNITS_MM = {
    0: 1.0,
    1: 25.4,  # inches
    2: 304.8,  # feet
    4: 1.0,  # millimetres
    5: 10.0,  # centimetres
    6: 1000.0,  # metres
    8: 25.4e-6,  # microinches
    9: 0.0254,  # mils
    10: 914.4,  # yards
    13: 1e-3,  # micrometres
    14: 100.0,  # decimetres
}


#: Most measured points kept for registration, inspection and the forces. A
#: longer file is read whole (every value checked) and every k-th point kept,
#: k = ceil(rows / MAX_MEASURED_POINTS): still 200 points a tooth at z = 1000,
#: ten times the 20 a tooth the registration needs (``POINTS_PER_TOOTH``).
MAX_MEASURED_POINTS = 200_000
#: Chord error of a DXF contour's arcs and splines flattened to points, mm.
FLATTEN_MM = 1e-4
#: Most points a DXF contour is flattened to (64 MB of coordinates), whatever
#: the budget: its arcs and splines are counted before any point is made
#: (:mod:`corr_cad.export.dxf_flatten`). A straight polyline of more vertices
#: is read as it is.
MAX_FLATTENED_POINTS = 4_000_000
#: Memory a flattened point holds while the contour is read, bytes: its
#: coordinates, their copy in mm and the kept points' check.
FLAT_BYTES_PER_POINT = 48
#: Bytes of a CSV read and parsed at a time.
_BLOCK_BYTES = 4 << 20
#: Longest header line read, bytes.
_MAX_HEADER = 64 << 10


@dataclass(frozen=True)
class MeasuredRead:
    """Points read from a measured profile, and how many the file held."""

    points: np.ndarray
    #: Data rows (CSV, blank lines aside) or contour points (DXF) in the file.
    rows: int
    #: Every ``stride``-th row kept (1: all).
    stride: int

    def as_dict(self) -> dict:
        return {"rows": self.rows, "kept": int(len(self.points)), "stride": self.stride}


def read_measured_points(
    path: Path, design=None, max_points: int | None = MAX_MEASURED_POINTS
) -> np.ndarray:
    """Points (n, 2) in mm from a CSV ``x,y``, a DXF's closed contour or a ring mesh.

    A mesh (``.stl`` binary or ASCII, ``.ply``) is sliced at mid face width
    and its inner loop taken (:mod:`corr_cad.export.measured_mesh`); it needs
    the ``design`` (face width and rim to check the mesh against).

    The CSV may start with a UTF-8 byte-order mark and ``#`` comment lines
    (as ``inner_gear_nominal.csv`` does); header names are read
    without surrounding blanks and case (``x, y``, ``X,Y``). For a DXF the
    contour is taken from layer ``MEASURED_PROFILE`` if present, else
    ``WORKING_PROFILE``, and scaled to mm by the header's ``$INSUNITS``. Only
    a regular file of at most ``MAX_MEASURED_BYTES`` is read. A
    self-intersecting contour is refused. Beyond ``max_points`` points every
    k-th is kept (:func:`read_measured`).
    """
    return read_measured(path, max_points, design).points


def read_measured(
    path: Path,
    max_points: int | None = MAX_MEASURED_POINTS,
    design=None,
    max_flat_points: int | None = MAX_FLATTENED_POINTS,
) -> MeasuredRead:
    """:func:`read_measured_points` with the file's row count and the stride kept.

    A CSV is streamed: read ``_BLOCK_BYTES`` at a time (every value is parsed
    and checked), only every k-th row kept, so memory does not grow with the
    file. A DXF is read by ezdxf (whole, its size bounded by the estimate); its
    contour's arcs and splines are flattened to at most ``max_flat_points``
    points, counted before any is made.
    """
    from corr_cad.export.inputfiles import check_regular_file

    path = Path(path)
    size = check_regular_file(path, "measured profile", MAX_MEASURED_BYTES, error=ProfileError)
    if is_mesh(path):
        if design is None:
            raise ProfileError(f"{_shown(path)}: a mesh needs the design to be sliced (face width)")
        from corr_cad.export.inputfiles import read_regular_file

        raw = read_regular_file(path, "measured profile", MAX_MEASURED_BYTES, error=ProfileError)
        pts = read_mesh_profile(raw, path.suffix, design, str(path))
        del raw
        rows = len(pts)
        stride = _stride(rows, max_points)
        pts = pts[::stride]
    elif path.suffix.lower() == ".dxf":
        _refuse_control_bytes(path, "DXF")
        pts = _read_dxf(path, max_flat_points)
        rows = len(pts)
        stride = _stride(rows, max_points)
        pts = pts[::stride]
    else:
        _refuse_control_bytes(path, "CSV")
        pts, rows, stride = _read_csv(path, size, max_points)
    if len(pts) >= 4 and np.all(np.isfinite(pts)):
        _refuse_outliers(pts, path)
        ring = shapely.LinearRing(pts)
        if not ring.is_simple:
            raise ProfileError(f"{_shown(path)}: the contour intersects itself")
    return MeasuredRead(pts, rows, stride)


#: A point farther from the axis than this many times the median radius is an outlier.
OUTLIER_RADIUS = 2.0


def _refuse_outliers(pts: np.ndarray, path: Path) -> None:
    """Refuse a point far off the ring (a stray probe point, a 1e308 typed in).

    Such a point would dominate the fit (its square overflows from 1.3e154 mm)
    or make the contour cross itself; it is named instead. The median radius
    is robust to a few of them, and a whole file in other units (all points
    far out) passes to the units check.
    """
    r = np.hypot(pts[:, 0] / 2, pts[:, 1] / 2)  # halved: no overflow at 1.7e308
    median = float(np.median(r))
    worst = int(np.argmax(r))
    if r[worst] > OUTLIER_RADIUS * median:
        x, y = pts[worst]
        count = int(np.count_nonzero(r > OUTLIER_RADIUS * median))
        raise ProfileError(
            f"{_shown(path)}: {count} point{'s' if count > 1 else ''} far off the ring, e.g. "
            f"({x:.6g}, {y:.6g}) at {2 * r[worst]:.3g} mm from the axis, more than "
            f"{OUTLIER_RADIUS:g} times the median radius {2 * median:.4g} mm; remove such "
            "outliers (stray probe points?)"
        )


def _stride(rows: int, max_points: int | None) -> int:
    return 1 if not max_points or rows <= max_points else -(-rows // max_points)


def _read_dxf(path: Path, max_points: int | None = MAX_FLATTENED_POINTS) -> np.ndarray:
    import ezdxf

    from corr_cad.export.dxf_flatten import FlatteningTooLarge

    try:
        doc = ezdxf.readfile(str(path))
        layers = {e.dxf.layer for e in doc.modelspace()}
        units = int(doc.header.get("$INSUNITS", 0))
    except Exception as exc:
        raise ProfileError(f"{_shown(path)}: not a readable DXF file ({_brief(exc)})") from exc
    if units not in INSUNITS_MM:
        raise ProfileError(
            f"{_shown(path)}: $INSUNITS = {units} is not a length unit corr_cad reads; "
            f"one of {', '.join(str(k) for k in INSUNITS_MM)} (4 = mm)"
        )
    layer = "MEASURED_PROFILE" if "MEASURED_PROFILE" in layers else "WORKING_PROFILE"
    try:
        pts, _ = dxf.read_closed_contour(
            path,
            layer,
            flatten_distance=FLATTEN_MM / INSUNITS_MM[units],
            max_points=max_points,
            doc=doc,
        )
    except FlatteningTooLarge as exc:
        need = exc.points * FLAT_BYTES_PER_POINT
        size = f"{need / 2**20:.3g} MB" if need < 2**30 else f"{need / 2**30:.3g} GB"
        raise ProfileError(
            f"{_shown(path)}: layer {layer}: {exc} (chords within {FLATTEN_MM * 1e3:g} um, "
            f"about {size} of memory); at most {exc.allowed} are read: is the file in mm "
            "about the gear axis?"
        ) from exc
    except Exception as exc:
        raise ProfileError(f"{_shown(path)}: {_brief(exc)}") from exc
    return pts * INSUNITS_MM[units]


def _lines(fh, rest: bytes = b""):
    """Blocks of whole lines (bytes) from ``fh``, ``_BLOCK_BYTES`` at a time (at most
    ``MAX_MEASURED_BYTES`` in all: a file that grows while it is read is not followed)."""
    total = 0
    while True:
        block = fh.read(_BLOCK_BYTES)
        total += len(block)
        if total > MAX_MEASURED_BYTES:
            raise ValueError(f"it grew beyond {MAX_MEASURED_BYTES} bytes while read")
        if not block:
            if rest:
                yield rest
            return
        block = rest + block
        cut = block.rfind(b"\n") + 1
        if cut == 0:
            rest = block
            if len(rest) > 16 * _BLOCK_BYTES:
                raise ValueError(f"a line longer than {16 * _BLOCK_BYTES} bytes")
            continue
        rest = block[cut:]
        yield block[:cut]


def _shown(path: Path) -> str:
    return show(str(path), 120)


#: The first bytes of a binary DXF (AutoCAD's "DXB"-less binary DXF), which ezdxf reads.
BINARY_DXF = b"AutoCAD Binary DXF\r\n\x1a\x00"


def _refuse_control_bytes(path: Path, kind: str) -> None:
    """Refuse a text file holding control or NUL bytes, naming where, quoting nothing
    (a binary DXF, which ezdxf reads, aside)."""
    from corr_cad.export.inputfiles import first_control_byte

    try:
        with open(path, "rb") as fh:
            if kind == "DXF" and fh.read(len(BINARY_DXF)) == BINARY_DXF:
                return
        found = first_control_byte(path)
    except OSError as exc:
        raise ProfileError(
            f"measured profile {_shown(path)} cannot be read: {show(exc.strerror or str(exc), 100)}"
        ) from exc
    if found is not None:
        offset, line = found
        raise ProfileError(
            f"{_shown(path)}: line {line} (byte {offset}) holds a control or NUL character: "
            f"not a text {kind} file (is it the right file?); nothing of it is shown; "
            + ("write x,y rows in mm" if kind == "CSV" else "export the contour as ASCII DXF")
        )


def _quote(value: object, limit: int) -> str:
    """``value`` for an error line (cut to ``limit``), unless it holds non-printable text."""
    from corr_cad.export.inputfiles import quotable

    text = show(value, limit)
    return text if quotable(text) else "(not shown: non-printable characters)"


def _brief(exc: BaseException, limit: int = 100) -> str:
    """An exception's message cut short: it may quote the file it failed on, and is
    left out where it holds control characters or escaped bytes (only its kind shown)."""
    from corr_cad.export.inputfiles import quotable

    text = str(exc)
    if not text or not quotable(text):
        return type(exc).__name__
    return show(text, limit)


def _head(fh) -> tuple[bytes, int]:
    """The header line and its line number: leading ``#`` comment lines are skipped."""
    head = fh.readline(_MAX_HEADER)
    first = 1
    while head.lstrip(b"\xef\xbb\xbf").startswith(b"#") and first < 100:
        head, first = fh.readline(_MAX_HEADER), first + 1
    return head, first


def _count_lines(fh) -> int:
    """Lines from here to the end (the last one may lack its newline)."""
    lines = 0
    for block in _lines(fh):
        lines += block.count(b"\n") + (not block.endswith(b"\n"))
    return lines


def csv_points_kept(path: Path, max_points: int | None = MAX_MEASURED_POINTS) -> tuple[int, int]:
    """``(lines, kept)`` of a measured CSV without parsing it: the lines below its header,
    which set the stride, and the points :func:`read_measured` keeps of them (every
    ``stride``-th; a blank line counts as a point, so ``kept`` is an upper bound).
    Counting reads the file once, about 0.1 s for 100 MB; a file that cannot be read
    counts (0, 0) (the stage reports it)."""
    try:
        with open(path, "rb") as fh:
            _head(fh)
            lines = _count_lines(fh)
    except (OSError, ValueError):
        return 0, 0
    return lines, len(range(0, lines, _stride(lines, max_points)))


def _read_csv(path: Path, size: int, max_points: int | None) -> tuple[np.ndarray, int, int]:
    """Stream a CSV: count its lines, then parse every row, keeping every k-th.

    Errors name the line where the bad record starts and quote at most 40
    characters of it (a stray quote would otherwise echo the rest of the file).
    """
    shown = _shown(path)
    try:
        with open(path, "rb") as fh:
            head, first = _head(fh)
            body_start = fh.tell()
            text = head.decode("utf-8-sig")
            header = [h.strip().lower() for h in next(csv.reader([text]), [])]
            if "x" not in header or "y" not in header:
                raise ProfileError(
                    f"{shown}: expected a CSV with columns x,y (mm); the header is "
                    f"{_quote(header[:4], 60)}"
                )
            ix, iy = header.index("x"), header.index("y")
            stride = _stride(_count_lines(fh), max_points)
            fh.seek(body_start)
            kept, rows, line = [], 0, first + 1  # the file's line number of the block's start
            for block in _lines(fh):
                decoded = block.decode("utf-8")
                rows_text = [r for r in decoded.splitlines() if r.strip(" \t,")]
                if rows_text:
                    try:
                        vals = _parse_rows(rows_text, ix, iy)
                    except ValueError:
                        _raise_bad_row(decoded, line, ix, iy, shown)
                        raise
                    kept.append(vals[(-rows) % stride :: stride])
                    rows += len(vals)
                line += block.count(b"\n")
    except ProfileError:
        raise
    except OSError as exc:
        raise ProfileError(
            f"measured profile {shown} cannot be read: {show(exc.strerror or str(exc), 100)}"
        ) from exc
    except UnicodeDecodeError as exc:
        raise ProfileError(f"{shown}: cannot be read as CSV (not UTF-8: {exc.reason})") from exc
    except (csv.Error, ValueError) as exc:
        raise ProfileError(f"{shown}: cannot be read as CSV ({_brief(exc, 80)})") from exc
    pts = np.concatenate(kept) if kept else np.empty((0, 2))
    return pts, rows, stride


def _parse_rows(rows: list[str], ix: int, iy: int) -> np.ndarray:
    """``x, y`` of CSV rows (numpy's C parser; quotes and blanks as the csv module reads them)."""
    try:
        return np.loadtxt(
            rows, delimiter=",", usecols=(ix, iy), ndmin=2, dtype=float, quotechar='"'
        ).reshape(-1, 2)
    except (TypeError, IndexError) as exc:
        raise ValueError(str(exc)) from exc


def _raise_bad_row(text: str, first_line: int, ix: int, iy: int, shown: str) -> None:
    """Find the first bad record of a block with the csv module and raise naming its line."""
    reader = csv.reader(io.StringIO(text, newline=""))
    start = first_line
    try:
        while True:
            start = first_line + reader.line_num  # a quoted value may run over many lines
            row = next(reader, None)
            if row is None:
                return
            if not any(c.strip(" \t") for c in row):
                continue
            try:
                float(row[ix]), float(row[iy])
            except (ValueError, IndexError) as exc:
                cells = row[ix] if ix < len(row) else ""
                cells += "," + row[iy] if iy < len(row) else ""
                quote = (
                    " (a stray quote joins the lines after it into one)" if "\n" in cells else ""
                )
                raise ProfileError(
                    f"{shown}: line {start}: x,y = {_quote(cells, 40)}: a value is not a number"
                    + quote
                ) from exc
    except csv.Error as exc:
        raise ProfileError(
            f"{shown}: line {start}: cannot be read as CSV ({_brief(exc, 60)}; a stray quote "
            "joins the lines after it into one value)"
        ) from exc


def write_deviation_dxf(
    design,
    working: ProfileCurve,
    registered_points: np.ndarray,
    deviation: np.ndarray,
    t: np.ndarray,
    exaggeration: float,
    path: Path,
    tolerance: float,
) -> Path:
    """Nominal, measured (registered) and exaggerated profiles on their own layers."""
    doc = dxf._new_doc(design, "measured_profile", {"corr_cad.exaggeration": exaggeration})
    msp = doc.modelspace()
    nominal = approximate(working, "polyline", tolerance)
    dxf._add_profile(msp, nominal, dxf._layer(doc, "WORKING_PROFILE"))
    order = np.argsort(np.mod(t, 2 * np.pi))
    dxf._add_bulge_polyline(
        msp,
        registered_points[order],
        np.zeros(len(order)),
        {"layer": dxf._layer(doc, "MEASURED_PROFILE")},
    )
    tt = t[order]
    exag = working.points(tt) - exaggeration * deviation[order, None] * working.normals(tt)
    dxf._add_bulge_polyline(
        msp, exag, np.zeros(len(order)), {"layer": dxf._layer(doc, "DEVIATION_EXAGGERATED")}
    )
    return dxf._save(doc, path)
