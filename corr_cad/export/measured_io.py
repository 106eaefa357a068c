"""Reading measured profiles (CSV ``x,y`` mm, or a DXF contour); the comparison DXF."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import shapely

from ..errors import ProfileError
from ..profile import ProfileCurve
from ..sampling import approximate
from . import dxf

__all__ = ["read_measured_points", "write_deviation_dxf", "MEASURED_LAYERS"]

MEASURED_LAYERS = ("WORKING_PROFILE", "MEASURED_PROFILE", "DEVIATION_EXAGGERATED")


def read_measured_points(path: Path) -> np.ndarray:
    """Points (n, 2) from a CSV with columns ``x,y`` or from a DXF's closed contour.

    For a DXF the contour is taken from layer ``MEASURED_PROFILE`` if present,
    else ``WORKING_PROFILE``. A self-intersecting contour is refused.
    """
    path = Path(path)
    if not path.exists():
        raise ProfileError(f"measured profile {str(path)!r} does not exist")
    if path.suffix.lower() == ".dxf":
        import ezdxf

        try:
            layers = {e.dxf.layer for e in ezdxf.readfile(str(path)).modelspace()}
        except Exception as exc:
            raise ProfileError(
                f"{path}: not a readable DXF file ({exc or type(exc).__name__})"
            ) from exc
        layer = "MEASURED_PROFILE" if "MEASURED_PROFILE" in layers else "WORKING_PROFILE"
        try:
            pts, _ = dxf.read_closed_contour(path, layer, flatten_distance=1e-4)
        except Exception as exc:
            raise ProfileError(str(exc)) from exc
    else:
        try:
            with open(path, newline="", encoding="utf-8") as f:
                rows = list(csv.DictReader(f))
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            raise ProfileError(f"{path}: cannot be read as CSV ({exc})") from exc
        if not rows or not {"x", "y"} <= set(rows[0]):
            raise ProfileError(f"{path}: expected a CSV with columns x,y (mm)")
        try:
            pts = np.array([[float(r["x"]), float(r["y"])] for r in rows])
        except (TypeError, ValueError) as exc:
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
