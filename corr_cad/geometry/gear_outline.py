"""A gear's closed outline as a polyline within a stated tolerance, measured.

Each smooth segment of one pitch (:func:`~corr_cad.geometry.involute.tooth_segments`)
gets its own nodes, so no span crosses the corner where an involute meets
its tip circle; nodes are placed at equal sagitta (a chord ``c`` on a stretch
of radius ``R`` deviates by ``c^2 / (8 R)``), then every span is **measured**
in both directions with the converged projection of
:mod:`corr_cad.geometry.measure` (the ring's measurement), and a span that
exceeds the tolerance is split and measured again. The other teeth are exact
rotations.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from corr_cad.geometry.involute import GearTeeth, Segment, tooth_segments
from corr_cad.geometry.kinematics import rotate_by_polar_angle
from corr_cad.geometry.measure import DenseSampling, max_on_spans, project_points

__all__ = ["GearOutline", "approximate_gear", "GearSplines", "spline_gear"]

_SAGITTA_TARGET = 0.9
_MEASURE_SAMPLES = 16
_REFINE_ROUNDS = 12


@dataclass(frozen=True)
class GearOutline:
    """A gear's polyline outline and its measured deviation from the exact outline.

    Attributes
    ----------
    vertices : (n, 2) float, mm
        The closed outline of all teeth, growing polar angle, no repeated end.
    kinds : (n,) str
        The segment kind (``root``, ``fillet``, ``involute``, ``tip``) of the span
        leaving each vertex.
    max_deviation, exact_to_export, export_to_exact : float, mm
    deviation_by_kind : dict
        ``{kind: max deviation}``, mm.
    tolerance : float, mm
    """

    vertices: np.ndarray
    kinds: np.ndarray
    max_deviation: float
    exact_to_export: float
    export_to_exact: float
    deviation_by_kind: dict
    tolerance: float

    @property
    def within_tolerance(self) -> bool:
        return bool(self.max_deviation <= self.tolerance)

    def as_dict(self) -> dict:
        return {
            "representation": "polyline",
            "tolerance_mm": self.tolerance,
            "max_deviation_mm": self.max_deviation,
            "exact_to_export_mm": self.exact_to_export,
            "export_to_exact_mm": self.export_to_exact,
            "within_tolerance": self.within_tolerance,
            "vertex_count": int(len(self.vertices)),
            "max_deviation_by_segment_mm": dict(self.deviation_by_kind),
        }


def _curvature(seg: Segment, u: np.ndarray) -> np.ndarray:
    d1 = seg.derivative(u)
    h = 1e-4
    d2 = (seg.derivative(u + h) - seg.derivative(u - h)) / (2 * h)
    cross = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    return cross / np.maximum(np.linalg.norm(d1, axis=-1) ** 3, 1e-300)


def _initial_nodes(seg: Segment, tol: float) -> np.ndarray:
    u = np.linspace(0.0, 1.0, 2049)
    speed = np.linalg.norm(seg.derivative(u), axis=-1)
    dens = np.sqrt(_curvature(seg, u) / (8.0 * _SAGITTA_TARGET * tol)) * speed
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(u))])
    n = max(2, int(math.ceil(cum[-1])))
    if cum[-1] <= 0:
        return np.linspace(0.0, 1.0, n + 1)
    return np.interp(np.linspace(0.0, cum[-1], n + 1), cum, u)


def _point_segment_distance(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return np.linalg.norm(q - (a + t[:, None] * ab), axis=-1)


def _measure(seg: Segment, nodes: np.ndarray, dense: DenseSampling) -> tuple:
    """Per span: (exact -> chord, chord -> exact) maxima, mm."""
    p = seg.points(nodes)
    du = np.diff(nodes)

    def fwd(span, u):
        q = seg.points(nodes[span] + u * du[span])
        return _point_segment_distance(q, p[span], p[span + 1])

    def bwd(span, u):
        q = p[span] + u[:, None] * (p[span + 1] - p[span])
        return project_points(seg.points, seg.derivative, dense, q).distance

    n = len(nodes) - 1
    return max_on_spans(fwd, n, _MEASURE_SAMPLES), max_on_spans(bwd, n, _MEASURE_SAMPLES)


def _approximate_segment(seg: Segment, tol: float) -> tuple[np.ndarray, float, float]:
    nodes = _initial_nodes(seg, tol)
    dense = DenseSampling.build(seg.points, seg.derivative, 0.0, 1.0, 2048)
    for round_ in range(_REFINE_ROUNDS + 1):
        f, b = _measure(seg, nodes, dense)
        bad = np.maximum(f, b) > tol
        if not np.any(bad) or round_ == _REFINE_ROUNDS:
            break
        nodes = np.sort(np.concatenate([nodes, 0.5 * (nodes[:-1] + nodes[1:])[bad]]))
    return nodes, float(f.max()), float(b.max())


def approximate_gear(g: GearTeeth, tolerance: float) -> GearOutline:
    """The closed polyline outline of ``g`` within ``tolerance`` (mm), measured.

    >>> import math
    >>> from corr_cad.geometry.involute import GearTeeth
    >>> o = approximate_gear(GearTeeth(18, 1.5, math.radians(20), 0.5), 0.001)
    >>> o.within_tolerance, sorted(o.deviation_by_kind)
    (True, ['fillet', 'involute', 'root', 'tip'])

    Made once per process for the same gear and tolerance (the last eight kept):
    the outline is read-only, shared by the DXF, the meshes and the STEP stage,
    and by a pool worker forked after the main process made it.
    """
    return _approximate_gear(g, float(tolerance))


@functools.lru_cache(maxsize=8)
def _approximate_gear(g: GearTeeth, tol: float) -> GearOutline:
    piece, kinds = [], []
    fwd_max = bwd_max = 0.0
    by_kind: dict[str, float] = {}
    segs = tooth_segments(g)
    # The - side mirrors the + side (u -> 1 - u, x -> -x): approximate and measure once.
    plus = {i: _approximate_segment(segs[i], tol) for i in range(len(segs) // 2, len(segs))}
    for i, seg in enumerate(segs):
        if i in plus:
            nodes, f, b = plus[i]
        else:
            nodes, f, b = plus[len(segs) - 1 - i]
            nodes = 1.0 - nodes[::-1]
        pts = seg.points(nodes[:-1])
        piece.append(pts)
        kinds += [seg.kind] * len(pts)
        fwd_max, bwd_max = max(fwd_max, f), max(bwd_max, b)
        by_kind[seg.kind] = max(by_kind.get(seg.kind, 0.0), f, b)
    tooth = np.concatenate(piece)
    pitch = 2.0 * math.pi / g.teeth
    # Tooth 0 runs from -pitch/2 to +pitch/2; its copies turn by whole pitches (a
    # rotation moves a point by round-off, 1e-13 mm, off the exact outline).
    verts = np.concatenate([rotate_by_polar_angle(tooth, k * pitch) for k in range(g.teeth)])
    kind_arr = np.array(kinds * g.teeth)
    verts.flags.writeable = kind_arr.flags.writeable = False  # shared: see approximate_gear
    return GearOutline(
        verts,
        kind_arr,
        max(fwd_max, bwd_max),
        fwd_max,
        bwd_max,
        by_kind,
        tol,
    )


#: Segment kinds of a gear outline that are arcs about the gear's centre.
ARC_KINDS = ("root", "tip")


@dataclass(frozen=True)
class GearSplines:
    """Tooth 0's outline as one clamped cubic B-spline per smooth segment, measured.

    ``splines`` are scipy ``BSpline`` objects on ``u`` in ``[0, 1]``, in the order of
    :func:`~corr_cad.geometry.involute.tooth_segments`, ``kinds`` their segment
    kinds; a root or a tip is an arc about the gear's centre, exact between its
    neighbours' ends, and has ``None`` in place of a spline. The other teeth are
    rotations by whole pitches. ``max_deviation`` is the splines', measured
    both ways (mm).
    """

    splines: list
    teeth: int
    max_deviation: float
    tolerance: float
    kinds: tuple[str, ...]

    @property
    def within_tolerance(self) -> bool:
        return bool(self.max_deviation <= self.tolerance)


class _Piece:
    """A :class:`Segment` as the curve the spline approximation of the ring expects."""

    piece_t_range = (0.0, 1.0)

    def __init__(self, seg: Segment):
        self.points, self.derivative = seg.points, seg.derivative


def spline_gear(g: GearTeeth, tolerance: float) -> GearSplines:
    """Each smooth segment as a cubic B-spline within ``tolerance`` (mm), measured.

    The nodes, the interpolating spline and the two-way measurement are those of
    the ring's ``spline`` representation (:mod:`corr_cad.geometry.sampling`).
    """
    from scipy.interpolate import BSpline

    from corr_cad.geometry.sampling import _measure_spline, _piece_spline, _spline_nodes

    tol = float(tolerance)
    splines, worst = [], 0.0
    segs = tooth_segments(g)
    for seg in segs[len(segs) // 2 :]:
        if seg.kind in ARC_KINDS:
            splines.append(None)
            continue
        piece = _Piece(seg)
        dense = DenseSampling.build(seg.points, seg.derivative, 0.0, 1.0, 2048)
        # Bisected from the segment's two ends: as few spans as the tolerance
        # allows (each written several times over in every STEP file that holds
        # the gear).
        nodes = _spline_nodes(piece, 0.5 * tol, 4096, start=2)
        for round_ in range(_REFINE_ROUNDS + 1):
            spl = _piece_spline(piece, nodes)
            f, b = _measure_spline(piece, dense, nodes, spl)
            bad = np.maximum(f, b) > 0.5 * tol
            if not np.any(bad) or round_ == _REFINE_ROUNDS:
                break
            nodes = np.sort(np.concatenate([nodes, 0.5 * (nodes[:-1] + nodes[1:])[bad]]))
        splines.append(spl)
        worst = max(worst, float(f.max()), float(b.max()))
    # the - side: the mirror image, run backwards
    minus = [
        None
        if spl is None
        else BSpline((1.0 - spl.t)[::-1], spl.c[::-1] * np.array([-1.0, 1.0]), spl.k)
        for spl in reversed(splines)
    ]
    return GearSplines(minus + splines, g.teeth, worst, tol, tuple(s.kind for s in segs))
