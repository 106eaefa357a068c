"""Wire-EDM cut of the inner gear's tooth opening: wire path, lead-in, checks.

What is cut and on which side
-----------------------------
The ring keeps the material *outside* the working profile; the opening
inside it (where cam and rollers run) is the scrap slug. The wire centre
therefore runs at distance ``d = wire_diameter/2 + spark_gap`` from the
working profile *into the opening*. The working profile is the locus offset
outwards by ``r``, and offsets of one curve along the same normals add, so
the wire-centre path is again an exact offset of the roller-centre locus:
``P(t) + (r - d) n(t)``. It is a valid offset (no swallowtail) exactly
where ``1 + (r - d) k > 0``, i.e. ``d < 1/k_w`` wherever the working
profile's curvature ``k_w = k / (1 + r k)`` is positive. Those are the tooth
spaces: pockets in the ring whose centre of curvature lies in the opening
(concave for the ring, the corners a wire cannot reach into if it is too
thick). Their smallest radius is the limit checked here.

The path is approximated by tangent-continuous arcs (``sampling.approximate``
with ``"arcs"``), rounded to the program's number format, and the written
path is measured against the exact offset curve: each arc is sampled and its
worst point refined (golden section) and projected onto the exact curve with
Newton. The written path is continuous, closed and winds once, so every
exact point is the foot of some written point; the one-sided maximum is
therefore the two-sided (Hausdorff) deviation.

Lead-in
-------
At the chosen point ``Q`` (unit tangent ``T`` in the cutting direction,
``N`` into the opening) the wire comes from the start-hole centre
``H = Q + 2 rho N - rho T`` along a straight line to ``Q + rho N - rho T``
and a quarter arc of radius ``rho = lead_in_length / 2`` centred at
``Q + rho N``, which meets the contour tangentially. The lead-out is the
mirror quarter arc, then a straight line back to ``H``. ``Q`` is where the
rollers carry least over the cycle (largest gear force seen at that profile
point, from the solver when forces were computed), ties broken towards the
tooth tip; without forces it is the tooth tip. Pure numpy/scipy.

Cutter compensation and direction
---------------------------------
With ``compensation = "path"`` the offset ``d`` is in the path, as above,
and the cut runs clockwise seen from +Z. With ``"G41"`` or ``"G42"`` the
path is the working profile itself and the control offsets the wire by its
D register. Going round the opening clockwise, the opening (the scrap) lies
to the right of the path: G42 (wire right of the path in the direction of
travel) keeps the wire in the scrap. G41 keeps it on the left, so with G41
the whole program runs counterclockwise. Either way the straight part of the
lead-in (and of the lead-out) is ``lead_in_length / 2`` long, which must
exceed twice the offset: LinuxCNC wants the move after G40 longer than the
wire diameter, and every control needs the lead-in arc (radius
``lead_in_length / 2``) larger than the offset.

Slug stop
---------
With ``slug_stop_mm > 0`` the contour is split (on the same arc or line, so
tangency is kept) that far before it closes; :attr:`EdmProgram.slug_stop_index`
is the first move after the stop. The writer puts the program stop there,
so the slug is still held by that much uncut material.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import optimize

from corr_cad.errors import SceneError
from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.profile import ProfileCurve
from corr_cad.geometry.projection import signed_normal_distance
from corr_cad.geometry.sampling import approximate
from corr_cad.shop.bulge import bulge_centre, reverse, seg_length, split_at, split_tail

__all__ = [
    "COMPENSATIONS",
    "EdmSpec",
    "Move",
    "EdmProgram",
    "smallest_concave_radius",
    "lead_in_psi",
    "check_lead_in",
    "check_lead_in_steps",
    "gcode_decimals",
    "plan_cut",
]

#: ``[edm] compensation``: offset in the path, or by the control to the left/right.
COMPENSATIONS = ("path", "G41", "G42")

#: The lead-in arc must span at least this many of the G-code's coordinate
#: steps: shorter, its rounded ends collapse onto one point (a lead-in of one
#: step at 4 decimals was still written, a tenth of a step was not).
LEAD_IN_STEPS = 10


def gcode_decimals(tolerance: float) -> int:
    """Decimals of the written coordinates: a step of at most a tenth of ``tolerance``."""
    return max(4, math.ceil(1.0 - math.log10(tolerance) - 1e-9))


def check_lead_in_steps(lead_in_length: float, tolerance: float) -> None:
    """Refuse a lead-in shorter than :data:`LEAD_IN_STEPS` G-code steps at ``tolerance``.

    Its arc's rounded ends would fall on one point of the coordinate grid.
    """
    step = 10.0 ** -gcode_decimals(tolerance)
    low = LEAD_IN_STEPS * step
    if lead_in_length < low:
        raise SceneError(
            f"[edm] lead_in_length = {lead_in_length:g}: allowed range at [export] tolerance = "
            f"{tolerance:g} is [{low:g}, 50] mm (at least {LEAD_IN_STEPS} of the G-code's "
            f"{step:g} mm steps); lead_in_length = {low:g} would work"
        )


@dataclass(frozen=True)
class EdmSpec:
    """``[edm]`` settings, mm and mm/min."""

    wire_diameter: float = 0.25
    spark_gap: float = 0.02
    start_hole_diameter: float = 3.0
    lead_in_length: float = 2.0
    feed_mm_per_min: float = 2.0
    compensation: str = "path"
    slug_stop_mm: float = 0.0

    @property
    def offset(self) -> float:
        """Wire-centre offset from the finished profile: wire radius plus spark gap, mm."""
        return 0.5 * self.wire_diameter + self.spark_gap

    @property
    def clockwise(self) -> bool:
        """Cut direction seen from +Z: clockwise but with G41 (see the module text)."""
        return self.compensation != "G41"


@dataclass(frozen=True)
class Move:
    """One programmed move, exactly as written (rounded coordinates).

    ``kind`` is ``"line"`` or ``"arc"``; an arc has its ``centre`` (start
    plus the written I, J) and ``clockwise`` (G02) or not (G03).
    """

    kind: str
    start: tuple[float, float]
    end: tuple[float, float]
    centre: tuple[float, float] | None = None
    clockwise: bool = False

    @property
    def sweep_rad(self) -> float:
        """Signed sweep (+ counter-clockwise) of an arc, from start to end about the centre."""
        c = np.asarray(self.centre)
        a0 = math.atan2(self.start[1] - c[1], self.start[0] - c[0])
        a1 = math.atan2(self.end[1] - c[1], self.end[0] - c[0])
        sw = (a1 - a0) % (2 * math.pi)
        return sw - 2 * math.pi if self.clockwise else sw

    @property
    def bulge(self) -> float:
        return math.tan(self.sweep_rad / 4.0) if self.kind == "arc" else 0.0

    def points(self, u: np.ndarray, radius_at: float = 0.0) -> np.ndarray:
        """Points at fractions ``u`` (m,) of the move.

        An arc whose rounded ends are not exactly equidistant from its centre
        is traced at the start radius (``radius_at = 0``), the end radius (1)
        or a blend: controllers differ, the measurement takes the worst.
        """
        u = np.asarray(u, dtype=float)
        a, b = np.asarray(self.start), np.asarray(self.end)
        if self.kind == "line":
            return a + u[:, None] * (b - a)
        c = np.asarray(self.centre)
        r0, r1 = np.linalg.norm(a - c), np.linalg.norm(b - c)
        a0 = math.atan2(a[1] - c[1], a[0] - c[0])
        ang = a0 + u * self.sweep_rad
        rad = r0 + radius_at * (r1 - r0) + 0.0 * u
        return c + rad[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)

    def tangent(self, at_end: bool) -> np.ndarray:
        """Unit direction of travel at the start or end."""
        if self.kind == "line":
            v = np.subtract(self.end, self.start)
            return v / np.linalg.norm(v)
        p = np.asarray(self.end if at_end else self.start) - np.asarray(self.centre)
        v = np.array([p[1], -p[0]]) if self.clockwise else np.array([-p[1], p[0]])
        return v / np.linalg.norm(v)


@dataclass(frozen=True)
class EdmProgram:
    """A complete wire path: start hole, lead-in, closed contour, lead-out."""

    spec: EdmSpec
    start_hole_centre: tuple[float, float]
    lead_in: tuple[Move, ...]
    contour: tuple[Move, ...]
    lead_out: tuple[Move, ...]
    decimals: int
    tolerance: float
    approximation_deviation: float
    written_deviation: float
    smallest_concave_radius: float
    smallest_concave_psi_deg: float
    lead_in_point: dict = field(default_factory=dict)
    start_hole_clearance: float = 0.0
    lead_in_kink_deg: float = 0.0
    slug_stop_index: int | None = None
    #: The working profile cut: ``conjugate ...`` or ``modified: <families and amounts>``
    #: (:func:`corr_cad.geometry.modification.describe_profile`); empty if not given.
    profile: str = ""

    @property
    def modified(self) -> bool:
        return self.profile.startswith("modified")

    def as_dict(self) -> dict:
        comp = self.spec.compensation
        path_side = (
            "the modified working profile offset by wire_offset"
            if self.modified
            else "locus offset by roller_radius - wire_offset"
        )
        side = (
            f"into the opening (the scrap slug); wire centre path = {path_side}"
            if comp == "path"
            else f"into the opening (the scrap slug), by the control: {comp} keeps the wire "
            f"{'left' if comp == 'G41' else 'right'} of the programmed working profile"
        )
        return {
            **({"profile": self.profile} if self.profile else {}),
            "wire_diameter_mm": self.spec.wire_diameter,
            "spark_gap_mm": self.spec.spark_gap,
            "wire_offset_mm": self.spec.offset,
            "compensation": comp,
            "cut_direction": "clockwise" if self.spec.clockwise else "counterclockwise",
            "offset_side": side,
            "start_hole_diameter_mm": self.spec.start_hole_diameter,
            "start_hole_centre_mm": list(self.start_hole_centre),
            "start_hole_edge_to_profile_mm": self.start_hole_clearance,
            "lead_in_length_mm": self.spec.lead_in_length,
            "feed_mm_per_min": self.spec.feed_mm_per_min,
            "tolerance_mm": self.tolerance,
            "approximation_deviation_mm": self.approximation_deviation,
            "max_deviation_mm": self.written_deviation,
            "coordinate_decimals": self.decimals,
            "contour_moves": len(self.contour),
            "smallest_concave_radius_mm": self.smallest_concave_radius,
            "smallest_concave_radius_psi_deg": self.smallest_concave_psi_deg,
            "lead_in_point": self.lead_in_point,
            "lead_in_kink_deg": self.lead_in_kink_deg,
            "slug_stop_mm": self.spec.slug_stop_mm if self.slug_stop_index is not None else 0.0,
        }


def smallest_concave_radius(working: ProfileCurve) -> tuple[float, float]:
    """Smallest radius of the working profile where its centre of curvature is in the opening.

    Returns ``(radius_mm, psi_deg)``; ``inf`` if the profile is nowhere so curved.
    """
    z, e, L, r = working.tooth_count, working.eccentricity, working.link_length, working.offset

    def kw(psi):
        if getattr(working, "normal", None) is not None:  # a modification's normal table
            return working.curvature(np.asarray(psi, dtype=float) / z)
        k = kin.locus_curvature(psi, z, e, L)
        return k / (1.0 + r * k)

    psi = np.linspace(0.0, math.pi, 4097)
    v = kw(psi)
    i = int(np.argmax(v))
    if v[i] <= 0:
        return math.inf, float("nan")
    lo, hi = psi[max(i - 1, 0)], psi[min(i + 1, psi.size - 1)]
    best_psi, best = float(psi[i]), float(v[i])
    if hi > lo:
        res = optimize.minimize_scalar(
            lambda p: -float(kw(p)), bounds=(lo, hi), method="bounded", options={"xatol": 1e-12}
        )
        if -res.fun > best:
            best_psi, best = float(res.x), float(-res.fun)
    return 1.0 / best, math.degrees(best_psi)


def lead_in_psi(z: int, forces=None, bins: int = 720) -> dict:
    """Where the lead-in joins: ``psi`` of least peak gear force over the cycle.

    ``forces`` is a solver result (``psi`` and ``F_n`` arrays, positions x
    rollers) or None (then the tooth tip, ``psi = 180 deg``). Every contact
    at ``psi`` touches the working profile at the point of the roller centre
    ``t = psi / z`` of that tooth; the peak over all rollers and positions is
    taken per bin of ``360 / bins`` degrees, and among the least-loaded bins
    the one nearest the tooth tip is chosen.
    """
    if forces is None:
        return {
            "psi_deg": 180.0,
            "source": "tooth tip (no forces computed)",
            "peak_gear_force_N": None,
        }
    step = 2 * math.pi / bins
    psi = np.angle(np.exp(1j * np.asarray(forces.psi, dtype=float).ravel()))
    k = np.round(psi / step).astype(int) % bins  # bin k centred at k step
    peak = np.full(bins, np.nan)
    np.fmax.at(peak, k, np.asarray(forces.F_n, dtype=float).ravel())
    ok = np.isfinite(peak)
    least = np.nanmin(peak)
    cand = np.flatnonzero(ok & (peak <= least + 1e-9 * max(1.0, np.nanmax(peak))))
    centre = cand * step
    dist_tip = np.abs(np.angle(np.exp(1j * (centre - math.pi))))
    best = int(cand[int(np.argmin(dist_tip))])
    psi_deg = math.degrees(np.angle(np.exp(1j * best * step)))
    if abs(abs(psi_deg) - 180.0) < 1e-9:
        psi_deg = 180.0
    return {
        "psi_deg": psi_deg,
        "source": f"solver: least peak gear force over the cycle ({bins} bins of psi)",
        "peak_gear_force_N": float(least),
        "bin_width_deg": 360.0 / bins,
        "positions": int(np.asarray(forces.psi).shape[0]),
    }


def _round_pt(p, dec: int) -> tuple[float, float]:
    return (round(float(p[0]), dec), round(float(p[1]), dec))


def _arc_move(a, b, centre, clockwise: bool, dec: int) -> Move:
    """An arc with its ends rounded and its centre at the start plus rounded I, J.

    Of the rounded centres next to the exact one, the one giving the least
    difference between start and end radius is taken.
    """
    a_r, b_r = _round_pt(a, dec), _round_pt(b, dec)
    q = 10.0**-dec
    ij0 = np.round(np.asarray(centre) - np.asarray(a_r), dec)
    best = None
    for di in (-q, 0.0, q):
        for dj in (-q, 0.0, q):
            ij = (round(ij0[0] + di, dec), round(ij0[1] + dj, dec))
            c = np.array([a_r[0] + ij[0], a_r[1] + ij[1]])
            mis = abs(np.linalg.norm(np.subtract(a_r, c)) - np.linalg.norm(np.subtract(b_r, c)))
            key = (round(mis / q, 6), abs(di) + abs(dj))
            if best is None or key < best[0]:
                best = (key, ij)
    ij = best[1]
    c = (round(a_r[0] + ij[0], dec), round(a_r[1] + ij[1], dec))
    return Move("arc", a_r, b_r, c, bool(clockwise))


def _measure(curve: ProfileCurve, moves: tuple[Move, ...], samples: int = 17) -> float:
    """Largest distance of the written moves from the exact curve (sampled, then refined).

    Arcs are traced at their start radius and at their end radius (they
    differ by the rounding of the centre); the worst of both is returned.
    """
    return max(_measure_at(curve, moves, samples, ra) for ra in (0.0, 1.0))


def _moves_at(moves: tuple[Move, ...], ra: float):
    """Points of every move at its own fractions: ``f(uu)``, ``uu`` (n, k) -> (n * k, 2).

    The same arithmetic as :meth:`Move.points` element for element (the same
    bits), over all moves at once; each move's radius and start angle are
    computed once, by the same calls.
    """
    n = len(moves)
    a = np.array([m.start for m in moves], dtype=float)
    d = np.array([m.end for m in moves], dtype=float) - a
    arc = np.array([m.kind != "line" for m in moves])
    c, a0, sweep, rad = np.zeros((n, 2)), np.zeros(n), np.zeros(n), np.zeros(n)
    for i in np.flatnonzero(arc):
        m = moves[i]
        ci, ai, bi = np.asarray(m.centre), np.asarray(m.start), np.asarray(m.end)
        r0, r1 = np.linalg.norm(ai - ci), np.linalg.norm(bi - ci)
        c[i], a0[i], sweep[i] = ci, math.atan2(ai[1] - ci[1], ai[0] - ci[0]), m.sweep_rad
        rad[i] = r0 + ra * (r1 - r0)

    def at(uu: np.ndarray) -> np.ndarray:
        line = a[:, None, :] + uu[:, :, None] * d[:, None, :]
        ang = a0[:, None] + uu * sweep[:, None]
        circ = c[:, None, :] + rad[:, None, None] * np.stack([np.cos(ang), np.sin(ang)], axis=2)
        return np.where(arc[:, None, None], circ, line).reshape(-1, 2)

    return at


def _measure_at(curve: ProfileCurve, moves: tuple[Move, ...], samples: int, ra: float) -> float:
    u = np.linspace(0.0, 1.0, samples)
    at = _moves_at(moves, ra)
    pts = at(np.broadcast_to(u, (len(moves), samples)))
    d, t = signed_normal_distance(curve, pts)
    d = np.abs(d).reshape(len(moves), samples)
    t = t.reshape(len(moves), samples)
    k = np.argmax(d, axis=1)
    lo = u[np.clip(k - 1, 0, samples - 1)]
    hi = u[np.clip(k + 1, 0, samples - 1)]
    seed = t[np.arange(len(moves)), k]
    g = 0.5 * (math.sqrt(5.0) - 1.0)

    def dist_at(uu):
        p = at(np.asarray(uu, dtype=float)[:, None])
        return np.abs(signed_normal_distance(curve, p, seed)[0])

    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = dist_at(x1), dist_at(x2)
    for _ in range(30):
        left = f1 > f2
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        n1 = np.where(left, hi - g * (hi - lo), x2)
        n2 = np.where(left, x1, lo + g * (hi - lo))
        fn = dist_at(np.where(left, n1, n2))
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
        x1, x2 = n1, n2
    return float(max(d.max(), np.max(np.maximum(f1, f2))))


def check_lead_in(spec: EdmSpec) -> None:
    """With G41/G42 the straight lead-in and lead-out must be longer than twice the offset.

    The control ramps the offset on along the straight lead-in and off along
    the straight lead-out (LinuxCNC: the move after G40 must be longer than
    the tool diameter), and the lead-in arc of radius ``lead_in_length / 2``
    must stay larger than the offset. Raises :class:`SceneError`.
    """
    if spec.compensation == "path":
        return
    rho, d = 0.5 * spec.lead_in_length, spec.offset
    if rho <= 2.0 * d:
        raise SceneError(
            f"[edm] lead_in_length = {spec.lead_in_length:g}: with compensation = "
            f'"{spec.compensation}" the straight lead-in and lead-out (lead_in_length / 2) must '
            f"be longer than twice the wire offset {d:g} mm (the control ramps the offset on and "
            f"off there); allowed range is ({4.0 * d:g}, 50], e.g. lead_in_length = "
            f"{max(2.0, math.ceil(8.0 * d)):g}"
        )


def plan_cut(
    working: ProfileCurve,
    spec: EdmSpec,
    tolerance: float,
    forces=None,
    max_centre_offset: float = math.inf,
    profile: str = "",
) -> tuple[EdmProgram, ProfileCurve]:
    """The wire path for the opening of ``working``; returns it and the exact path curve.

    The path curve is the offset curve (``compensation = "path"``) or the
    working profile itself (G41/G42). An arc whose centre lies more than
    ``max_centre_offset`` from its start in X or Y (an I or J word the
    control cannot take; nearly straight) is written as a line; the measured
    deviation includes that. ``profile`` names the working profile for the
    files (:attr:`EdmProgram.profile`). ``forces``: a solver result the run
    already has, or None (the lead-in then goes to the tooth tip, by
    geometry; no forces are solved here). Raises :class:`SceneError` when the wire cannot
    reach the tooth spaces, the start hole does not fit in the opening, the
    lead-in is too short for the compensation or the slug stop too long.
    """
    if working.has_corners:
        raise SceneError(
            "[export] formats 'edm': the working profile is trimmed (allow_undercut = true); "
            "a wire path around its sharp tooth tips is not supported"
        )
    if spec.compensation not in COMPENSATIONS:
        raise SceneError(
            f"[edm] compensation = {spec.compensation!r}: must be one of {', '.join(COMPENSATIONS)}"
        )
    d = spec.offset
    r_min, psi_min = smallest_concave_radius(working)
    if d >= r_min:
        raise SceneError(
            f"[edm] wire_diameter = {spec.wire_diameter:g}, spark_gap = {spec.spark_gap:g}: "
            f"wire offset {d:g} mm must be below the smallest concave radius of the profile seen "
            f"from the scrap side, {r_min:.6g} mm (tooth space, psi {psi_min:.4g} deg)"
        )
    check_lead_in(spec)
    z, r = working.tooth_count, working.offset
    # The wire path keeps the profile's own shape (a modification's normal table too).
    path = replace(working, offset=r - (d if spec.compensation == "path" else 0.0))
    decimals = gcode_decimals(tolerance)
    check_lead_in_steps(spec.lead_in_length, tolerance)
    quantum = 10.0**-decimals
    approx = approximate(path, "arcs", tolerance - 3.0 * quantum)
    verts, bulges = approx.vertices, approx.bulges
    if not spec.clockwise:
        verts, bulges = reverse(verts, bulges)

    choice = lead_in_psi(z, forces)
    t_q = math.radians(choice["psi_deg"]) / z
    q = path.points(np.array([t_q]))[0]
    min_len = 10.0 * quantum
    verts, bulges, q_on = split_at(verts, bulges, q, min_len)
    slug_index = None
    if spec.slug_stop_mm > 0.0:
        n = len(verts)
        total = sum(seg_length(verts[i], verts[(i + 1) % n], bulges[i]) for i in range(n))
        if spec.slug_stop_mm >= 0.5 * total:
            raise SceneError(
                f"[edm] slug_stop_mm = {spec.slug_stop_mm:g}: the contour is {total:.4g} mm "
                f"long; allowed range is 0 or [0.1, {0.5 * total:.4g}), e.g. slug_stop_mm = 1"
            )
        verts, bulges, slug_index = split_tail(verts, bulges, spec.slug_stop_mm, min_len)

    dec = decimals
    contour = []
    n = len(verts)
    for i in range(n):
        a, b, bu = verts[i], verts[(i + 1) % n], bulges[i]
        centre = bulge_centre(a, b, bu) if bu != 0.0 else None
        if centre is None or np.max(np.abs(centre - a)) > max_centre_offset:
            contour.append(Move("line", _round_pt(a, dec), _round_pt(b, dec)))
        else:
            contour.append(_arc_move(a, b, centre, bu < 0, dec))
    contour = tuple(contour)
    # Lead-in at the written start point, tangent to the first written move.
    q_w = np.asarray(contour[0].start)
    tan = contour[0].tangent(at_end=False)
    n_in = -working.normals(np.array([t_q]))[0]
    n_in = n_in - np.dot(n_in, tan) * tan
    n_in /= np.linalg.norm(n_in)
    rho = 0.5 * spec.lead_in_length
    c_in = q_w + rho * n_in
    s_in = q_w + rho * n_in - rho * tan
    hole = q_w + 2 * rho * n_in - rho * tan
    turn_cw = float(tan[0] * n_in[1] - tan[1] * n_in[0]) < 0  # N to the right of T
    lead_in = (
        Move("line", _round_pt(hole, dec), _round_pt(s_in, dec)),
        _arc_move(_round_pt(s_in, dec), q_w, c_in, turn_cw, dec),
    )
    end_tan = contour[-1].tangent(at_end=True)
    kink = math.degrees(
        max(
            math.acos(min(1.0, float(np.dot(lead_in[-1].tangent(True), tan)))),
            math.acos(min(1.0, float(np.dot(end_tan, tan)))),
        )
    )
    s_out = q_w + rho * n_in + rho * tan
    lead_out = (
        _arc_move(q_w, s_out, c_in, turn_cw, dec),
        Move("line", _round_pt(s_out, dec), _round_pt(hole, dec)),
    )
    # The start hole must lie in the scrap: its edge inside the opening.
    dist, _ = signed_normal_distance(working, np.asarray([_round_pt(hole, dec)]))
    clearance = -float(dist[0]) - 0.5 * spec.start_hole_diameter
    if clearance <= 0.0:
        raise SceneError(
            f"[edm] start_hole_diameter = {spec.start_hole_diameter:g}: the start hole does not "
            f"fit in the scrap region; its centre is {-float(dist[0]):.4g} mm from the profile "
            f"(lead_in_length = {spec.lead_in_length:g}), so the diameter must stay below "
            f"{-2 * float(dist[0]):.4g} mm"
        )
    written = _measure(path, contour)
    tip = abs(abs(choice["psi_deg"]) - 180.0) < 1e-9
    info = dict(choice)
    info.update(
        {
            "t_deg": math.degrees(t_q),
            "where": "tooth tip between tooth spaces 1 and 2"
            if tip
            else f"flank of tooth space 1 at psi {choice['psi_deg']:.4g} deg "
            f"({180 - abs(choice['psi_deg']):.4g} deg from the tooth tip)",
            "point_mm": [float(q_w[0]), float(q_w[1])],
        }
    )
    prog = EdmProgram(
        spec,
        _round_pt(hole, dec),
        lead_in,
        contour,
        lead_out,
        decimals,
        float(tolerance),
        approx.max_deviation,
        written,
        r_min,
        psi_min,
        info,
        clearance,
        kink,
        slug_index,
        profile,
    )
    return prog, path
