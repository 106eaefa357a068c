"""Closed bulge polylines (DXF LWPOLYLINE style) of the wire path: split, reverse, lengths.

A polyline is ``verts`` (n, 2) with ``bulges`` (n,): segment ``i`` runs from
``verts[i]`` to ``verts[(i + 1) % n]``, a line for bulge 0, else an arc of
sweep ``4 atan(bulge)`` (+ counter-clockwise). Splitting keeps each arc's
circle, so tangency is kept. Pure numpy.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["bulge_centre", "seg_length", "reverse", "split_at", "split_tail"]


def bulge_centre(a: np.ndarray, b: np.ndarray, bulge: float) -> np.ndarray:
    """Centre of the arc from ``a`` to ``b`` with ``bulge`` (not 0)."""
    chord = b - a
    ln = float(np.hypot(*chord))
    left = np.array([-chord[1], chord[0]]) / ln
    return 0.5 * (a + b) + left * ((1.0 - bulge * bulge) / (4.0 * bulge)) * ln


def seg_length(a: np.ndarray, b: np.ndarray, bulge: float) -> float:
    """Length of one bulge segment (line or arc)."""
    chord = float(np.hypot(*(b - a)))
    if bulge == 0.0:
        return chord
    sweep = abs(4.0 * math.atan(bulge))
    return chord * (0.5 * sweep) / math.sin(0.5 * sweep)


def point_on(a: np.ndarray, b: np.ndarray, bulge: float, frac: float) -> np.ndarray:
    """The point at ``frac`` of the segment's sweep (arc) or length (line)."""
    if bulge == 0.0:
        return a + frac * (b - a)
    c = bulge_centre(a, b, bulge)
    a0 = math.atan2(*(a - c)[::-1])
    ang = a0 + frac * 4.0 * math.atan(bulge)
    return c + np.linalg.norm(a - c) * np.array([math.cos(ang), math.sin(ang)])


def reverse(verts: np.ndarray, bulges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The same closed bulge polyline run the other way round."""
    return verts[::-1].copy(), -np.roll(bulges[::-1], -1)


def split_tail(verts: np.ndarray, bulges: np.ndarray, tail: float, min_len: float):
    """Split the closed polyline (starting at ``verts[0]``) ``tail`` mm before it closes.

    Returns ``(verts, bulges, k)``: segment ``k`` is the first of the last
    ``tail`` mm. A split that would leave a piece shorter than ``min_len``
    moves to the nearest vertex instead.
    """
    n = len(verts)
    lengths = [seg_length(verts[i], verts[(i + 1) % n], bulges[i]) for i in range(n)]
    left = tail
    for i in range(n - 1, -1, -1):
        if lengths[i] < left - min_len:
            left -= lengths[i]
            continue
        if left <= min_len:  # the tail starts at vertex i + 1
            return verts, bulges, i + 1
        if lengths[i] - left <= min_len:  # ... or at vertex i
            return verts, bulges, i
        a, b, bu = verts[i], verts[(i + 1) % n], bulges[i]
        frac = 1.0 - left / lengths[i]  # arcs: length is proportional to sweep
        p = point_on(a, b, bu, frac)
        sweep = 4.0 * math.atan(bu)
        v = np.vstack([verts[: i + 1], p, verts[i + 1 :]])
        bl = np.r_[bulges[:i], math.tan(frac * sweep / 4.0), math.tan((1 - frac) * sweep / 4.0)]
        return v, np.r_[bl, bulges[i + 1 :]], i + 1
    raise AssertionError("tail longer than the contour")


def split_at(verts: np.ndarray, bulges: np.ndarray, q: np.ndarray, min_len: float = 0.0):
    """Re-start the closed bulge polyline at the point of its arc nearest ``q``.

    Returns ``(verts, bulges, q_on_path)`` beginning at that point; the arc
    that held it is split in two arcs of the same circle (tangency kept).
    A split that would leave a piece shorter than ``min_len`` starts at the
    nearer vertex instead (no move of a few number quanta, and never an arc
    whose rounded ends coincide: that would be a full circle).
    """
    n = len(verts)
    j = int(np.argmin(np.linalg.norm(0.5 * (verts + np.roll(verts, -1, axis=0)) - q, axis=1)))
    # the nearest arc is j or a neighbour: pick the one whose circle point is closest
    best = None
    for i in (j - 1, j, j + 1):
        i %= n
        a, b, bu = verts[i], verts[(i + 1) % n], bulges[i]
        if bu == 0.0:
            d = b - a
            u = float(np.clip(np.dot(q - a, d) / np.dot(d, d), 0, 1))
            p, frac = a + u * d, u
        else:
            c = bulge_centre(a, b, bu)
            rad = np.linalg.norm(a - c)
            sweep = 4.0 * math.atan(bu)
            a0 = math.atan2(*(a - c)[::-1])
            aq = math.atan2(*(q - c)[::-1])
            rel = (aq - a0) % (2 * math.pi) if sweep > 0 else -((a0 - aq) % (2 * math.pi))
            frac = float(np.clip(rel / sweep, 0.0, 1.0))
            ang = a0 + frac * sweep
            p = c + rad * np.array([math.cos(ang), math.sin(ang)])
        dist = float(np.linalg.norm(p - q))
        if best is None or dist < best[0]:
            best = (dist, i, frac, p)
    _, i, frac, p = best
    sweep = 4.0 * math.atan(bulges[i])
    b1, b2 = math.tan(frac * sweep / 4.0), math.tan((1 - frac) * sweep / 4.0)
    seg = seg_length(verts[i], verts[(i + 1) % n], bulges[i])
    eps = max(1e-12, min_len / seg) if seg > 0 else 1e-12
    if frac < eps:  # already a vertex
        order = np.r_[np.arange(i, n), np.arange(0, i)]
        return verts[order], bulges[order], verts[i]
    if frac > 1 - eps:
        i = (i + 1) % n
        order = np.r_[np.arange(i, n), np.arange(0, i)]
        return verts[order], bulges[order], verts[i]
    order = np.r_[np.arange(i + 1, n), np.arange(0, i + 1)]
    v = np.vstack([p, verts[order]])
    bl = np.r_[b2, bulges[order]]
    bl[-1] = b1
    return v, bl, p
