"""The crankshaft and its support bearings in the drive's solve, and the compliance budget.

Coupling (:class:`CrankSupport`, :func:`solve_with_crank`)
---------------------------------------------------------
The drive (:mod:`corr_cad.mechanics.drive.drive`) solves both rows with the cams
on their eccentrics. With a crankshaft each eccentric's centre moves by
``w_c`` under both cams' bearing forces (the beam and its support bearings,
:mod:`corr_cad.mechanics.crank.crankshaft`, :mod:`corr_cad.mechanics.crank.support_bearing`)
and turns against the crank gear by its twist ``theta_c``. Both enter
where the cam's bearing displacement does: roller ``k`` of row ``c`` overlaps
by

    a_k (tau_g - theta_c) + h_k + n_k . (u_c + w_c)

(``tau_g`` the crank gear's rotation, ``u_c`` the cam on its needles). The
shaft is round and its supports are taken as isotropic (one roller on the
load line), so ``w`` is computed in eccentric A's frame (eccentric B's is
turned by ``pi`` plus the cam phase error) and turned into each
eccentric's. The drive's Newton is solved with ``w`` and ``theta`` given as
extra gaps; they are then updated from its forces until they repeat to
``CRANK_RTOL`` (a fixed point, accelerated by Anderson mixing of depth 3,
Walker & Ni, *SIAM J. Numer. Anal.* 49, 2011). The map is a contraction
whose rate is the shaft's share of the cams' compliance (a few per cent), so
it converges in a handful of solves. The returned rotation is the gear's,
``tau_g = tau_A + theta_A``.

Budget (:func:`budget_terms`)
-----------------------------
By virtual work (the solved forces, in equilibrium, on the solved
deformations, which are compatible), the crank moment's work on the
gear's rotation is the sum of each element's force times its own
deformation:

    M0 tau_g = sum_k F_k h_k + sum_j Q_j (delta_j + Pd / 2) + sum_c P_c . w_c^beam
               + sum_i R_i . d_i + sum_c M_c theta_c - sum_k F_k g_k

(contacts, needles with their clearance taken up, crankshaft bending and
shear, the beam's two terms apart, support bearings, crankshaft torsion,
the initial gaps of the errors). A
roller's ``F h`` splits exactly into its three contacts (``F`` times each
contact's approach). Divided by the output torque ``T`` each term is that
element's share of the windup ``theta = -tau_g / (z + 1)``: the terms add up
to it exactly, for any contact law, and each is positive (a force times the
deformation it causes). For linear elements this is the usual series split
``T c_i``; for the nonlinear ones it is the secant split at the solved
state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.mechanics.crank.crankshaft import Crankshaft
from corr_cad.mechanics.crank.support_bearing import SupportBearing
from corr_cad.mechanics.drive.drive_numerics import joined
from corr_cad.mechanics.drive.drive_restart import restart_from
from corr_cad.mechanics.palmgren import PALMGREN_FORCE_EXPONENT

__all__ = ["CrankSupport", "solve_with_crank", "budget_terms", "CRANK_RTOL"]

#: Relative change of the eccentric centres' deflection and twist at the fixed point.
CRANK_RTOL = 1e-12
_MAX_ITER = 80
_FLOOR_MM = 1e-15
_DEPTH = 3


@dataclass(frozen=True)
class CrankSupport:
    """The crankshaft on its two support bearings (``bearing`` None: rigid supports)."""

    shaft: Crankshaft
    bearing: SupportBearing | None = None
    bearing_2: SupportBearing | None = None
    #: How each part was given: ``"scene"`` or ``"derived from the design"``.
    shaft_source: str = "scene"
    bearing_source: str = "scene"
    #: The scene keys whose values were derived from the design.
    derived: tuple[str, ...] = ()

    @property
    def supports(self) -> tuple[SupportBearing | None, SupportBearing | None]:
        return self.bearing, self.bearing_2 if self.bearing_2 is not None else self.bearing

    def response(self, loads: np.ndarray, moments: np.ndarray, floor=None) -> dict:
        """The shaft's answer to the eccentric loads ``P`` (P, 2, 2) N (eccentric A's frame)
        and the rows' moments ``M`` (P, 2) N*mm: deflections ``w`` (P, 2, 2) mm (beam
        ``w_beam`` and supports ``w_supports``), twists ``theta`` (P, 2) rad, reactions ``R``
        and support displacements ``d`` (P, 2, 2). ``floor`` (P,) N: a reaction at most
        this large is round-off of a zero one, and its support stays centred in its
        clearance (the first newton of load takes the clearance up: a reaction of
        round-off must not)."""
        P = np.asarray(loads, dtype=float)
        cb, cs = self.shaft.beam_influence_parts()
        w_bend = np.einsum("ij,pjx->pix", cb, P)
        w_shear = np.einsum("ij,pjx->pix", cs, P)
        w_beam = w_bend + w_shear
        r1, r2 = self.shaft.reactions(P)
        R = np.stack([r1, r2], axis=1)
        d = np.zeros_like(R)
        for i, b in enumerate(self.supports):
            if b is None:
                continue
            mag = np.linalg.norm(R[:, i], axis=1)
            dr = b.displacement(mag)
            live = mag > (0.0 if floor is None else floor)
            with np.errstate(divide="ignore", invalid="ignore"):
                d[:, i] = np.where(live[:, None], R[:, i] * (dr / mag)[:, None], 0.0)
        w_sup = np.einsum("ci,pix->pcx", self.shaft.support_lever(), d)
        theta = np.asarray(moments, dtype=float) @ self.shaft.torsion_matrix().T
        return {
            "w": w_beam + w_sup,
            "w_beam": w_beam,
            "w_bending": w_bend,
            "w_shear": w_shear,
            "w_supports": w_sup,
            "theta": theta,
            "R": R,
            "d": d,
        }

    def as_dict(self) -> dict:
        b1, b2 = self.supports
        return {
            "derived_from_design": list(self.derived),
            "crankshaft": {**self.shaft.as_dict(), "source": self.shaft_source},
            "support_bearings": [
                {**(b.as_dict() if b else {"type": "rigid"}), "source": self.bearing_source}
                for b in (b1, b2)
            ],
        }


def _rotation(angle: float) -> np.ndarray:
    """Components in a frame turned by ``angle`` (from +y towards +x) -> the base frame."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, s], [-s, c]])


class _State:
    """What the fixed point needs of a drive solver's geometry (built once per solver)."""

    def __init__(self, solver):
        R = solver.R
        self.R = R
        self.base = (solver.geo, solver.geo_joined)
        g = solver.geo_joined
        self.a_c = np.where(g.loadable, g.advance, 0.0)
        self.a_m = np.where(g.loadable, g.arm, 0.0)
        self.n = solver.n
        phase = float(getattr(solver.errors[1], "cam_phase_error", 0.0) or 0.0)
        #: Eccentric c's frame -> eccentric A's frame.
        self.rot = (np.eye(2), _rotation(math.pi + phase))
        #: Cam B's phase error at each position where a solver stacks samples of their
        #: own (``cam_phases`` (P,), the Monte Carlo's blocks): eccentric B's rotation
        #: (P, 2, 2) per position.
        phases = getattr(solver, "cam_phases", None)
        self.rot_b = None
        if phases is not None:
            t = math.pi + np.asarray(phases, dtype=float)
            c, s = np.cos(t), np.sin(t)
            self.rot_b = np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], 1)

    def loads_and_moments(self, F: np.ndarray):
        """Eccentric loads ``P`` (P, 2, 2) in A's frame and row moments (P, 2)."""
        R = self.R
        P = np.empty((F.shape[0], 2, 2))
        M = np.empty((F.shape[0], 2))
        for c, sl in enumerate((slice(0, R), slice(R, 2 * R))):
            f = np.einsum("pk,pkx->px", F[:, sl], self.n[:, sl])
            if c == 1 and self.rot_b is not None:
                P[:, c] = -np.einsum("pyx,px->py", self.rot_b, f)
            else:
                P[:, c] = -(f @ self.rot[c].T)
            M[:, c] = np.sum(self.a_m[:, sl] * F[:, sl], axis=1)
        return P, M

    def own(self, w: np.ndarray) -> np.ndarray:
        """(P, 2, 2) vectors from A's frame into each eccentric's own."""
        if self.rot_b is not None:
            return np.stack([w[:, 0], np.einsum("py,pyx->px", w[:, 1], self.rot_b)], axis=1)
        return np.stack([w[:, c] @ self.rot[c] for c in (0, 1)], axis=1)

    def offsets(self, x: np.ndarray) -> np.ndarray:
        """Extra gaps (P, 2R) of the unknowns ``x`` (P, 5): ``w_A``, ``w_B`` in A's frame,
        ``theta_A - theta_B``."""
        R = self.R
        w = self.own(x[:, :4].reshape(-1, 2, 2))
        out = np.empty(self.a_c.shape)
        out[:, :R] = np.einsum("pkx,px->pk", self.n[:, :R], w[:, 0])
        out[:, R:] = np.einsum("pkx,px->pk", self.n[:, R:], w[:, 1])
        out[:, R:] += self.a_c[:, R:] * x[:, 4:5]
        return out

    def set_geometry(self, solver, off: np.ndarray | None) -> None:
        ga, gb = self.base[0]
        if off is None:
            solver.geo, solver.geo_joined = self.base
            return
        R = self.R
        ga = replace(ga, gap=np.where(ga.loadable, ga.gap + off[:, :R], ga.gap))
        gb = replace(gb, gap=np.where(gb.loadable, gb.gap + off[:, R:], gb.gap))
        solver.geo = (ga, gb)
        solver.geo_joined = joined(ga, gb)


def _map(crank: CrankSupport, st: _State, F: np.ndarray):
    P, M = st.loads_and_moments(F)
    # A reaction below 1e-9 of the rollers' forces is the round-off of a zero one (rows
    # that preload their cams at zero moment): its support stays centred.
    resp = crank.response(P, M, 1e-9 * np.sum(np.abs(F), axis=1))
    th = resp["theta"]
    g = np.concatenate([resp["w"].reshape(-1, 4), (th[:, 0] - th[:, 1])[:, None]], axis=1)
    return g, resp


def _restart(solver, target, sol, starts):
    """Positions the Newton missed, again from other solutions (drive_restart's rule)."""
    # With elastic bodies the bearing Newton alone would solve the rigid bodies' drive.
    if solver.bearings[0] is None or solver.bodies is not None:
        return sol
    return restart_from(solver, target, sol, starts)


def _warm(solver, target, prev):
    """The bearing Newton started from the previous iterate's solution (None where it does
    not settle everywhere: the caller then solves from the rigid start)."""
    if solver.bearings[0] is None or solver.bodies is not None:
        return None
    sol = solver._with_bearings(target, prev[0], prev[1], 0)
    return sol if np.all(sol[4] <= max(solver.rtol, 1e-9)) else None


def solve_with_crank(solver, target: float, inner) -> tuple:
    """The drive's ``solve`` with the crankshaft: ``(tau_g, F, u, Qs, rel, iterations)``.

    ``inner(target)`` is the drive's own solve of the current geometry.
    """
    crank = solver.crank
    st = getattr(solver, "_crank_geometry", None)
    if st is None:
        st = _State(solver)
        solver._crank_geometry = st
    history = getattr(solver, "_crank_history", [])
    P = len(solver.crank_angles)
    e = solver.design.eccentricity
    scale = np.array([1.0, 1.0, 1.0, 1.0, e])
    x = np.zeros((P, 5))
    # Start from the nearest moment solved before, scaled to this one (the shaft is
    # nearly linear): the fixed point then starts a few per cent off, not 100 %.
    same_sign = [h for h in history if h[0] * target > 0]
    if same_sign:
        t0, _, x0 = min(same_sign, key=lambda h: abs(h[0] - target))
        x = x0 * (target / t0)
    xs, gs = [], []
    # At zero moment a position whose cams float free in their clearance carries no force:
    # its deflection is the round-off of zero forces (1e-17..1e-13 mm), which no relative
    # test settles. There the fixed point stops within 1e-12 e (a femtometre's order).
    floor = 1e-300 if target != 0.0 else CRANK_RTOL * e
    prev = None
    iterations = 0
    try:
        for k in range(_MAX_ITER):
            st.set_geometry(solver, st.offsets(x))
            sol = _warm(solver, target, prev) if prev is not None else None
            if sol is None:
                sol = inner(target)
                near = [h[1] for h in sorted(history, key=lambda h: abs(h[0] - target))]
                sol = _restart(solver, target, sol, [prev, *near])
            iterations += sol[5]
            prev = sol
            if solver.bodies is not None:  # the next iterate's bodies start from this one's
                solver._bodies_start = solver.bodies.last_d
            g, _ = _map(crank, st, sol[1])
            if k == 0:
                _check_small(crank, g, e, target)
            r = (g - x) * scale
            size = np.max(np.abs(g * scale), axis=1)
            # 1e-15 mm: a deflection of round-off (rows preloading their cams at zero
            # moment load the shaft with round-off only) has settled; at zero moment
            # the floor above (cams floating free) is the larger.
            if np.all(np.max(np.abs(r), axis=1) <= CRANK_RTOL * size + max(floor, _FLOOR_MM)):
                break
            xs.append(x * scale)
            gs.append(g * scale)
            xs, gs = xs[-(_DEPTH + 1) :], gs[-(_DEPTH + 1) :]
            x = _anderson(xs, gs) / scale
        else:
            raise SolverError(
                f"crankshaft coupling at crank moment {target:g} N*mm: the eccentric centres' "
                f"deflection did not settle to {CRANK_RTOL:g} in {_MAX_ITER} solves (a shaft "
                "or support far softer than the drive's contacts: check [crankshaft] "
                "shaft_diameter and [bearings.crank], e.g. shaft_diameter = 60)"
            )
    finally:
        st.set_geometry(solver, None)
        solver._bodies_start = None
    solver._crank_history = [(target, sol, x), *history][:2]
    tau, F, u, Qs, rel, _ = sol
    _, resp = _map(crank, st, F)
    return tau + resp["theta"][:, 0], F, u, Qs, rel, iterations


def _check_small(crank, g: np.ndarray, e: float, target: float) -> None:
    """Refuse at once a crank that moves an eccentric's centre by more than the
    eccentricity under the first iterate's loads: the rollers' teeth are ``2 e`` deep, so
    the drive would come apart, and the beam is far outside its small deflections (a
    1 mm shaft: 572 mm, 80 solves and ~100 s before 'did not settle')."""
    moved = float(np.max(np.abs(g[:, :4]))) if g.size else 0.0
    if not moved > e:
        return
    d = crank.shaft.shaft_diameter
    # Bending goes as d^-4: the diameter that moves the centres by 1 % of e.
    good = min(math.ceil(d * (moved / (0.01 * e)) ** 0.25), crank.shaft.eccentric_diameter - 2 * e)
    raise SolverError(
        f"crankshaft coupling at crank moment {target:g} N*mm: [crankshaft] shaft_diameter "
        f"= {d:g} (with its support bearings) moves the eccentric centres by {moved:.3g} mm, "
        f"more than the eccentricity e = {e:g} mm (the rollers would leave the teeth); "
        f"stiffen the shaft or its supports, e.g. shaft_diameter = {good:g}"
    )


def _anderson(xs: list, gs: list) -> np.ndarray:
    """Anderson mixing (depth <= 3) per position of the iterates ``xs`` and images ``gs``."""
    f = [g - x for x, g in zip(xs, gs, strict=True)]
    if len(xs) < 2:
        return gs[-1]
    dF = np.stack([f[i + 1] - f[i] for i in range(len(f) - 1)], axis=2)  # (P, 5, m)
    dG = np.stack([gs[i + 1] - gs[i] for i in range(len(gs) - 1)], axis=2)
    A = np.einsum("pim,pin->pmn", dF, dF)
    b = np.einsum("pim,pi->pm", dF, f[-1])
    tr = np.trace(A, axis1=1, axis2=2)
    A = A + (1e-12 * tr + 1e-300)[:, None, None] * np.eye(A.shape[1])
    with np.errstate(all="ignore"):
        gamma = np.linalg.solve(A, b[:, :, None])[:, :, 0]
    gamma = np.where(np.isfinite(gamma), gamma, 0.0)
    return gs[-1] - np.einsum("pim,pm->pi", dG, gamma)


def budget_terms(solver, target: float, sol) -> dict[str, np.ndarray]:
    """Each element's work ``force . deformation`` (P,) N*mm at the solved state ``sol``
    (``solver.solve(target)``'s), by component; they add up to ``target * tau_g``."""
    st = getattr(solver, "_crank_geometry", None) or _State(solver)
    tau, F, u, Qs, _, _ = sol
    comp = solver.comp
    g0 = np.where(st.base[1].loadable, st.base[1].gap, 0.0)
    out: dict[str, np.ndarray] = {}
    names = ("contact_cam", "contact_ring", "contact_slot")
    geo = st.base[1]
    ws = [np.ones_like(geo.rho_n), geo.rho_n, np.abs(geo.rho_s)]
    for name, part in zip(names, _contact_parts(comp, F, ws), strict=True):
        out[name] = np.sum(F * part, axis=1)
    need = np.zeros(len(tau))
    if Qs is not None:
        for c, b in enumerate(solver.bearings):
            ej = b.directions()
            need += np.sum(Qs[c] * -(u[c] @ ej.T), axis=1)
    out["needle_bearings"] = need
    zero = np.zeros(len(tau))
    out["crankshaft_bending"] = zero
    out["crankshaft_shear"] = zero
    out["crankshaft_torsion"] = zero
    out["support_bearings"] = zero
    if solver.crank is not None:
        P, M = st.loads_and_moments(F)
        resp = solver.crank.response(P, M)
        out["crankshaft_bending"] = np.einsum("pcx,pcx->p", P, resp["w_bending"])
        out["crankshaft_shear"] = np.einsum("pcx,pcx->p", P, resp["w_shear"])
        out["support_bearings"] = np.einsum("pix,pix->p", resp["R"], resp["d"])
        out["crankshaft_torsion"] = np.sum(M * resp["theta"], axis=1)
    out["initial_gaps"] = -np.sum(F * g0, axis=1)
    if solver.bodies is not None:  # each body's F . C_body F (the approach d = C F)
        out.update(solver.bodies.work(F))
    return out


def _contact_parts(comp, F: np.ndarray, ws: list) -> list[np.ndarray]:
    """Each contact's share ``w_i delta_i(w_i F)`` of a roller's approach (cam, ring, slot);
    ``ws`` the contacts' force weights ``1, rho_n, |rho_s|``."""
    if getattr(comp, "explicit", False):  # Palmgren: K F^0.9 split by w_i^1.9
        x = PALMGREN_FORCE_EXPONENT
        total, _ = comp.value_and_slope(F)
        s = sum(w ** (1 + x) for w in ws)
        return [total * w ** (1 + x) / s for w in ws]
    if getattr(comp, "linear", False):
        s = sum(w**2 for w in ws)
        return [comp.slope0 * F * w**2 / s for w in ws]
    return [c.value_and_slope(F)[0] for c in comp.contacts]
