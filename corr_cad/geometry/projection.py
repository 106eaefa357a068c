"""Nearest points on an exact profile curve, for the shop-floor modules.

``edm`` measures its written wire path against the exact offset curve and
``inspection`` evaluates measured points per tooth; both need the foot point
of a point on a :class:`~corr_cad.geometry.profile.ProfileCurve` to round-off. This
module is their own projection (the DXF approximation keeps its own in
``sampling``): seeds from a dense sampling, then Newton on
``g(t) = (C(t) - q) . C'(t) = 0`` with ``C''`` from a central difference of
the exact ``C'``. Pure numpy/scipy.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.geometry.profile import ProfileCurve

__all__ = ["project", "signed_normal_distance"]


def _second_derivative(curve: ProfileCurve, t: np.ndarray) -> np.ndarray:
    h = 1e-5 * curve.tooth_pitch_rad
    return (curve.derivative(t + h) - curve.derivative(t - h)) / (2.0 * h)


def project(
    curve: ProfileCurve,
    q: np.ndarray,
    t_seed: np.ndarray | None = None,
    samples_per_tooth: int = 256,
    iterations: int = 40,
) -> tuple[np.ndarray, np.ndarray]:
    """Foot points of ``q`` (n, 2) on the closed ``curve``.

    Returns ``(t, foot)``: curve parameters (n,) rad, continuous with the
    seeds, and the foot points (n, 2) mm. Without ``t_seed`` the seed is the
    nearest point of a dense sampling (k-d tree). On a trimmed (cornered)
    profile ``t`` is kept inside the seed's tooth piece.
    """
    q = np.asarray(q, dtype=float).reshape(-1, 2)
    z = curve.tooth_count
    pitch = curve.tooth_pitch_rad
    t_a, t_b = curve.piece_t_range
    if t_seed is None:
        from scipy.spatial import cKDTree

        t_loc = np.linspace(t_a, t_b, samples_per_tooth + 1)[:-1]
        t_all = (t_loc[None, :] + pitch * np.arange(z)[:, None]).ravel()
        _, idx = cKDTree(curve.points(t_all)).query(q)
        t = t_all[idx].copy()
    else:
        t = np.asarray(t_seed, dtype=float).copy()
    lo = hi = None
    if curve.has_corners:
        m = np.floor((t - t_a) / pitch)
        lo, hi = t_a + m * pitch, t_b + m * pitch
    max_step = 0.125 * pitch
    for _ in range(iterations):
        c = curve.points(t)
        d1 = curve.derivative(t)
        d2 = _second_derivative(curve, t)
        r = c - q
        g = np.sum(r * d1, axis=1)
        dg = np.sum(d1 * d1, axis=1) + np.sum(r * d2, axis=1)
        dg = np.where(dg > 0, dg, np.sum(d1 * d1, axis=1))
        step = np.clip(-g / dg, -max_step, max_step)
        t = t + step
        if lo is not None:
            t = np.clip(t, lo, hi)
        if np.max(np.abs(step)) < 1e-13:  # rad; 1.5e-11 mm on a 150 mm profile
            break
    return t, curve.points(t)


def signed_normal_distance(
    curve: ProfileCurve, q: np.ndarray, t_seed: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Distance of ``q`` from ``curve`` along its outward normal (+ = away from the axis).

    Returns ``(distance, t)``. For the working profile, + is into the ring
    material (material removed), - is into the opening (material added).
    """
    t, foot = project(curve, q, t_seed)
    n = curve.normals(t)
    return np.sum((np.asarray(q, dtype=float).reshape(-1, 2) - foot) * n, axis=1), t


def arc_length_parameters(curve: ProfileCurve, t_a: float, t_b: float, spacing: float):
    """Parameters ``t`` splitting ``[t_a, t_b]`` into equal arc lengths of at most ``spacing``.

    Returns ``(t, step_mm, length_mm)``; ``t`` includes ``t_a`` and excludes ``t_b``.
    Arc length by 48-point Gauss-Legendre on 64 panels, inverted by Newton.
    """
    nodes, weights = np.polynomial.legendre.leggauss(48)
    edges = np.linspace(t_a, t_b, 65)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[1:] + edges[:-1])
    tt = mid[:, None] + half[:, None] * nodes[None, :]
    speed = np.linalg.norm(curve.derivative(tt.ravel()), axis=1).reshape(tt.shape)
    panel = np.sum(half[:, None] * weights[None, :] * speed, axis=1)
    cum = np.r_[0.0, np.cumsum(panel)]
    length = float(cum[-1])
    n = max(1, math.ceil(length / spacing - 1e-9))
    step = length / n
    target = step * np.arange(n)
    t = np.interp(target, cum, edges)

    def arc(tv):
        # integral from the panel start to tv, Gauss-Legendre on the sub-interval
        k = np.clip(np.searchsorted(edges, tv, side="right") - 1, 0, 63)
        a = edges[k]
        h = 0.5 * (tv - a)
        m = 0.5 * (tv + a)
        x = m[:, None] + h[:, None] * nodes[None, :]
        sp = np.linalg.norm(curve.derivative(x.ravel()), axis=1).reshape(x.shape)
        return cum[k] + np.sum(h[:, None] * weights[None, :] * sp, axis=1)

    for _ in range(8):
        t = t - (arc(t) - target) / np.linalg.norm(curve.derivative(t), axis=1)
    return t, step, length
