"""Numerics of the drive (:mod:`corr_cad.mechanics.drive`): inverting the paper's contact
law inside the bearing Newton, each row's free rotation at no load, and the two rows'
geometry joined.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.geometry.design import GearDesign
from corr_cad.mechanics.solver_geometry import RollerGeometry

__all__ = ["free_row", "joined", "roller_directions"]

#: ``|n_x|`` below which a roller's normal counts as along the eccentric (:func:`free_row`).
_FLAT = 1e-9


def free_row(a, g, n, half_clearance: float, e: float, want_centre: bool = False):
    """One row's free crank interval ``(rev, fwd)`` (P,) at no load, rad.

    Roller ``k`` stays clear while ``a_k tau + g_k + n_k . u <= 0``; the cam's
    centre may sit anywhere with ``|u| <= half_clearance``. Since ``a_k = e
    n_k,x``, with ``v = u + e tau x`` the rollers ask ``n_k . v <= -g_k`` (a
    convex polygon of ``v``) and the bearing ``|v - e tau x| <= Pd/2``, so

        e fwd = max over the polygon of v_x + sqrt((Pd/2)^2 - v_y^2)

    (and ``e rev`` the min of ``v_x - sqrt(...)``): concave in ``v_y``, found by
    golden-section searches over the polygon's horizontal slices. An empty
    interval (``rev > fwd``): the row is preloaded (no ``v`` leaves every roller
    clear). ``want_centre``: also the least-pressed ``v`` found, (P, 2), a start
    for the preloaded cam's own equilibrium.
    """
    up, down = a > 0, a < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -g / a
        fwd = np.min(np.where(up, t, np.inf), axis=1)
        rev = np.max(np.where(down, t, -np.inf), axis=1)
    if half_clearance == 0.0:
        return (rev, fwd, np.zeros((a.shape[0], 2))) if want_centre else (rev, fwd)
    c = half_clearance
    nx, ny = n[..., 0], n[..., 1]
    # A roller whose normal is (nearly) along the eccentric, psi = 0 or pi, bounds v_y only:
    # its slice bound -g / n_x would be a round-off quotient.
    right, left = nx > _FLAT, nx < -_FLAT
    flat = ~(right | left) & np.isfinite(g)

    def slice_at(y):
        """``(x_left, x_right, press)`` (P,) of the polygon's slice at ``v_y = y``."""
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = (-g - ny * y[:, None]) / nx
        xr = np.min(np.where(right, bound, np.inf), axis=1)
        xl = np.max(np.where(left, bound, -np.inf), axis=1)
        # How far a roller with no arm (psi = 0 or pi) is pressed: <= 0 to stay clear.
        press = np.max(np.where(flat, ny * y[:, None] + g, -np.inf), axis=1)
        return xl, xr, press

    def golden(fun, lo, hi, iterations=90):
        """Argmax of a concave ``fun`` on ``[lo, hi]`` (P,)."""
        ratio = 0.5 * (math.sqrt(5.0) - 1.0)
        x1, x2 = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        f1, f2 = fun(x1), fun(x2)
        for _ in range(iterations):
            left_better = f1 >= f2
            hi = np.where(left_better, x2, hi)
            lo = np.where(left_better, lo, x1)
            x2n = np.where(left_better, x1, lo + ratio * (hi - lo))
            x1n = np.where(left_better, hi - ratio * (hi - lo), x2)
            x1, x2 = x1n, x2n
            f1, f2 = fun(x1), fun(x2)
        return 0.5 * (lo + hi)

    def width(y):
        """Concave in ``y``; >= 0 where the slice is not empty."""
        xl, xr, press = slice_at(y)
        return np.minimum(np.minimum(xr - xl, 1e300), -press)

    P = a.shape[0]
    lo0, hi0 = np.full(P, -c), np.full(P, c)
    # Round-off allowance of the polygon: a nominal row pins v to one point.
    tol = 1e-12 * (c + np.max(np.where(np.isfinite(g), np.abs(g), 0.0), axis=1))
    y_mid = golden(width, lo0, hi0)
    feasible = width(y_mid) >= -tol

    def edge(inside, outside, iterations=80):
        for _ in range(iterations):
            mid = 0.5 * (inside + outside)
            ok = width(mid) >= -tol
            inside = np.where(ok, mid, inside)
            outside = np.where(ok, outside, mid)
        return inside

    y1, y2 = edge(y_mid, lo0), edge(y_mid, hi0)

    def reach(sense):
        def fun(y):
            xl, xr, _ = slice_at(y)
            arc = np.sqrt(np.maximum(c * c - y * y, 0.0))
            return (xr + arc) if sense > 0 else -(xl - arc)

        return sense * fun(golden(fun, y1, y2))

    e_fwd, e_rev = reach(1.0), reach(-1.0)
    fwd = np.where(feasible, e_fwd / e, -np.inf)
    rev = np.where(feasible, e_rev / e, np.inf)
    if want_centre:
        xl, xr, _ = slice_at(y_mid)
        mid = np.where(np.isfinite(xl + xr), 0.5 * (xl + xr), np.where(np.isfinite(xl), xl, xr))
        return rev, fwd, np.stack([np.where(np.isfinite(mid), mid, 0.0), y_mid], axis=1)
    return rev, fwd


def _forces_of(comp, h):
    """Roller forces and ``dF/dh`` at overlaps ``h`` for either contact law."""
    if getattr(comp, "explicit", False):
        return comp.force_and_stiffness(h)
    return _invert_convex(comp, h, np.maximum(h, 0.0) / comp.slope0)


def _invert_convex(comp, h, start):
    """``F`` with ``G(F) = h`` (0 where ``h <= 0``) and ``dF/dh``, for the paper's law.

    Newton from ``start``, to the right of the root (``G`` is convex and
    increasing, so the iterates decrease monotonically onto it), each roller
    until its step is below ``1e-15`` of its force (a few iterations from a
    tangent predictor; the one-row solver's own inversion asks for steps below
    round-off, which a few elements never reach). Only the loaded rollers are
    evaluated, and each only until it settles (the compiled inversion's rule,
    :mod:`corr_cad.mechanics.drive_kernel`): an unloaded roller or a settled
    one costs no evaluation of the law.
    """
    pos = h > 0
    F = np.zeros(h.shape)
    dg = np.ones(h.shape)
    where = np.flatnonzero(pos)  # flat indices of the rollers still iterating
    loaded = sub = comp.take(pos)  # their contacts, flat
    hs = h[pos]
    Fs = np.asarray(start, dtype=float)[pos]
    for _ in range(60):
        if where.size == 0:
            break
        g, d = sub.value_and_slope(Fs)
        step = (g - hs) / d
        Fs = np.maximum(Fs - step, 0.0)
        F.flat[where] = Fs
        going = ~(np.abs(step) <= 1e-15 * Fs + 1e-300)
        if not going.all():
            where, hs, Fs = where[going], hs[going], Fs[going]
            sub = sub.take(going)
    dg[pos] = loaded.value_and_slope(F[pos])[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        return F, np.where(F > 0, 1.0 / dg, 0.0)


def joined(ga: RollerGeometry, gb: RollerGeometry) -> RollerGeometry:
    """Both rows as one geometry of ``2 (z + 1)`` rollers (row A first)."""
    out = {}
    for k in RollerGeometry.__dataclass_fields__:
        a, b = getattr(ga, k), getattr(gb, k)
        if k == "k_cam":  # one per cam (a float, or (P, 1) when samples are stacked)
            out[k] = np.concatenate(
                [
                    np.broadcast_to(np.asarray(a, dtype=float), ga.psi.shape),
                    np.broadcast_to(np.asarray(b, dtype=float), gb.psi.shape),
                ],
                axis=1,
            )
        else:
            out[k] = np.concatenate([a, b], axis=1)
    return RollerGeometry(**out)


def roller_directions(design: GearDesign, geo: RollerGeometry) -> np.ndarray:
    """``n_k`` (P, R, 2): unit vector from the cam centre to roller ``k``, eccentric's frame.

    In the frame that turns with the eccentric (eccentric along +y), roller
    ``k`` sits at ``s_k (-sin psi_k, cos psi_k)`` and the cam centre at
    ``(0, e)``; their distance is ``L``.
    """
    e, L = design.eccentricity, design.link_length
    s, psi = geo.s, geo.psi
    return np.stack([-s * np.sin(psi) / L, (s * np.cos(psi) - e) / L], axis=-1)
