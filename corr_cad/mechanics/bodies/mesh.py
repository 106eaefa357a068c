"""A graded triangle mesh of a plane region bounded by polygons.

The bodies (:mod:`corr_cad.mechanics.bodies`) are meshed from the part
outlines the tool exports (:func:`corr_cad.geometry.parts.part_outlines`).
The mesher is a Delaunay triangulation (``scipy.spatial.Delaunay``) of

* points on each boundary polygon, spaced by the local mesh size ``h(x)``
  (on the polygon itself: its vertices' chords are the exported outline), and
* interior points of hexagonal lattices of spacing ``h0 2^l``, each level
  kept where ``h(x)`` is within a factor two of its spacing, away from the
  finer levels' points by ``0.6`` of its spacing and from the boundary by
  ``0.6`` of its spacing or of the boundary's there, whichever is larger,

of which the triangles whose centroid lies inside the region are kept. Every
boundary chord must come out as a triangle edge (boundary points closer to
each other than to any interior point make them Delaunay edges); the mesher
checks that and raises otherwise. Pure numpy, scipy and shapely.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import shapely
from scipy.spatial import Delaunay, cKDTree

from corr_cad.errors import SolverError

__all__ = ["resample_closed", "mesh_region", "min_angle_deg"]


def _densify(poly: np.ndarray, step: float) -> np.ndarray:
    """Points along the closed polygon ``poly`` (n, 2) no farther apart than ``step``."""
    a = np.asarray(poly, dtype=float)
    b = np.roll(a, -1, axis=0)
    seg = np.linalg.norm(b - a, axis=1)
    n = np.maximum(np.ceil(seg / step).astype(int), 1)
    out = [a[i] + (b[i] - a[i]) * (np.arange(n[i])[:, None] / n[i]) for i in range(len(a))]
    return np.vstack(out)


def resample_closed(poly: np.ndarray, h: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Points on the closed polygon ``poly`` (n, 2) spaced by the size ``h`` (m, 2)."""
    h_min = float(np.min(h(np.asarray(poly, dtype=float))))
    dense = _densify(poly, 0.1 * h_min)
    closed = np.vstack([dense, dense[:1]])
    ds = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    hm = h(0.5 * (closed[1:] + closed[:-1]))
    count = np.concatenate([[0.0], np.cumsum(ds / hm)])
    n = max(int(np.ceil(count[-1])), 8)
    target = np.arange(n) * count[-1] / n
    x = np.interp(target, count, closed[:, 0])
    y = np.interp(target, count, closed[:, 1])
    return np.stack([x, y], axis=1)


def _hex_lattice(lo: np.ndarray, hi: np.ndarray, spacing: float) -> np.ndarray:
    dy = spacing * np.sqrt(3.0) / 2.0
    ys = np.arange(lo[1], hi[1] + dy, dy)
    xs = np.arange(lo[0], hi[0] + spacing, spacing)
    X, Y = np.meshgrid(xs, ys)
    X = X + 0.5 * spacing * (np.arange(len(ys)) % 2)[:, None]
    return np.stack([X.ravel(), Y.ravel()], axis=1)


def mesh_region(
    outer: np.ndarray,
    holes: list[np.ndarray],
    h: Callable[[np.ndarray], np.ndarray],
    h0: float,
) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """Triangles of the region inside ``outer`` less ``holes`` (polygons (n, 2), mm).

    ``h`` gives the mesh size at points (m, 2) -> (m,), mm, never below ``h0``.
    Returns the points (N, 2), the triangles (M, 3) counter-clockwise, and each
    boundary's point indices in order (outer first, then the holes).
    """
    polys = [np.asarray(outer, dtype=float), *[np.asarray(p, dtype=float) for p in holes]]
    region = shapely.Polygon(polys[0], polys[1:])
    bnd = [resample_closed(p, h) for p in polys]
    bpts = np.vstack(bnd)
    dense_b = np.vstack([_densify(p, 0.25 * h0) for p in polys])
    tree_b = cKDTree(dense_b)
    h_b = h(dense_b)  # the boundary's spacing near each of its points
    lo, hi = bpts.min(axis=0), bpts.max(axis=0)
    kept: list[np.ndarray] = []
    h_top = float(np.max(h(bpts)))
    level = 0
    while True:
        sp = h0 * 2.0**level
        lat = _hex_lattice(lo, hi, sp)
        lat = lat[shapely.contains_xy(region, lat[:, 0], lat[:, 1])]
        hl = h(lat)
        top = 2.0 * sp > h_top * 1.000001
        lat = lat[(hl >= sp) & ((hl < 2.0 * sp) | top)]
        d_b, near = tree_b.query(lat)
        lat = lat[d_b >= 0.6 * np.maximum(sp, h_b[near])]
        if kept:
            d_f, _ = cKDTree(np.vstack(kept)).query(lat)
            lat = lat[d_f >= 0.6 * sp]
        kept.append(lat)
        if top:
            break
        level += 1
    pts = np.vstack([bpts, *kept])
    tri = Delaunay(pts).simplices
    cen = pts[tri].mean(axis=1)
    tri = tri[shapely.contains_xy(region, cen[:, 0], cen[:, 1])]
    # Counter-clockwise.
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    tri = np.where((cross < 0)[:, None], tri[:, [0, 2, 1]], tri)
    # Boundary points on one straight chord of the outline are collinear: the hull's
    # zero-area triangles among them are no part of the region.
    tri = tri[np.abs(cross) > 1e-9 * h0 * h0]
    # Every boundary chord must be an edge of exactly one triangle.
    edges = np.sort(np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    uniq, counts = np.unique(edges, axis=0, return_counts=True)
    free = {tuple(e) for e in uniq[counts == 1]}
    start, loops = 0, []
    for b in bnd:
        idx = np.arange(start, start + len(b))
        loops.append(idx)
        chords = np.sort(np.stack([idx, np.roll(idx, -1)], axis=1), axis=1)
        missing = [tuple(c) for c in chords if tuple(c) not in free]
        if missing:
            raise SolverError(
                f"body mesh: {len(missing)} boundary chords are not triangle edges "
                f"(mesh size {h0:g} mm too coarse for the outline)"
            )
        start += len(b)
    if len(free) != sum(len(b) for b in bnd):
        raise SolverError("body mesh: the triangles leave a free edge inside the region")
    used = np.unique(tri)
    remap = np.full(len(pts), -1)
    remap[used] = np.arange(len(used))
    loops = [remap[idx] for idx in loops]
    return pts[used], remap[tri], loops


def min_angle_deg(points: np.ndarray, triangles: np.ndarray) -> float:
    """The smallest interior angle of the mesh, degrees."""
    p = points[triangles]
    worst = 180.0
    for i in range(3):
        u = p[:, (i + 1) % 3] - p[:, i]
        v = p[:, (i + 2) % 3] - p[:, i]
        cos = np.sum(u * v, axis=1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
        worst = min(worst, float(np.degrees(np.arccos(np.clip(cos, -1, 1))).min()))
    return worst
