"""Reading measured profiles (CSV ``x,y`` mm, or a DXF contour); the comparison DXF."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import shapely

from corr_cad.errors import ProfileError
from corr_cad.export import dxf
from corr_cad.export.measured_mesh import is_mesh, read_mesh_profile
from corr_cad.geometry.profile import ProfileCurve
from corr_cad.geometry.sampling import approximate

__all__ = [
    "read_measured_points",
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


def read_measured_points(path: Path, design=None) -> np.ndarray:
    """Points (n, 2) in mm from a CSV ``x,y``, a DXF's closed contour or a ring mesh.

    A mesh (``.stl`` binary or ASCII, ``.ply``) is sliced at mid face width
    and its inner loop taken (:mod:`corr_cad.export.measured_mesh`); it needs
    the ``design`` (face width and rim to check the mesh against).

    The CSV may start with a UTF-8 byte-order mark; header names are read
    without surrounding blanks and case (``x, y``, ``X,Y``). For a DXF the
    contour is taken from layer ``MEASURED_PROFILE`` if present, else
    ``WORKING_PROFILE``, and scaled to mm by the header's ``$INSUNITS``. Only
    a regular file of at most ``MAX_MEASURED_BYTES`` is read. A
    self-intersecting contour is refused.
    """
    from corr_cad.export.inputfiles import read_regular_file

    path = Path(path)
    raw = read_regular_file(path, "measured profile", MAX_MEASURED_BYTES, error=ProfileError)
    if is_mesh(path):
        if design is None:
            raise ProfileError(f"{path}: a mesh needs the design to be sliced (face width)")
        pts = read_mesh_profile(raw, path.suffix, design, str(path))
    elif path.suffix.lower() == ".dxf":
        import ezdxf

        try:
            doc = ezdxf.readfile(str(path))
            layers = {e.dxf.layer for e in doc.modelspace()}
            units = int(doc.header.get("$INSUNITS", 0))
        except Exception as exc:
            raise ProfileError(
                f"{path}: not a readable DXF file ({exc or type(exc).__name__})"
            ) from exc
        if units not in INSUNITS_MM:
            raise ProfileError(
                f"{path}: $INSUNITS = {units} is not a length unit corr_cad reads; "
                f"one of {', '.join(str(k) for k in INSUNITS_MM)} (4 = mm)"
            )
        layer = "MEASURED_PROFILE" if "MEASURED_PROFILE" in layers else "WORKING_PROFILE"
        try:
            pts, _ = dxf.read_closed_contour(path, layer, flatten_distance=1e-4)
        except Exception as exc:
            raise ProfileError(str(exc)) from exc
        pts = pts * INSUNITS_MM[units]
    else:
        try:
            text = raw.decode("utf-8-sig")
            reader = csv.reader(io.StringIO(text, newline=""))
            header = [h.strip().lower() for h in next(reader, [])]
            rows = list(reader)
        except (UnicodeDecodeError, csv.Error) as exc:
            raise ProfileError(f"{path}: cannot be read as CSV ({exc})") from exc
        if "x" not in header or "y" not in header:
            raise ProfileError(
                f"{path}: expected a CSV with columns x,y (mm); the header is {header[:4]}"
            )
        ix, iy = header.index("x"), header.index("y")
        try:
            pts = np.array(
                [[float(r[ix]), float(r[iy])] for r in rows if any(c.strip() for c in r)],
                dtype=float,
            ).reshape(-1, 2)
        except (TypeError, ValueError, IndexError) as exc:
            raise ProfileError(f"{path}: a value is not a number ({exc})") from exc
    if len(pts) >= 4 and np.all(np.isfinite(pts)):
        ring = shapely.LinearRing(pts)
        if not ring.is_simple:
            raise ProfileError(f"{path}: the contour intersects itself")
    return pts


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
