"""The windup primitive and the datasheet figures (issue 19 items 1-3).

Each expected value comes from something the code under test does not use:
closed forms written out here (roller-centre distance, moment arm, force
ratios, the Hertz linear-contact limit), the exact clearance geometry of
:mod:`corr_cad.geometry.clearance` with the crank really locked and the
frame really turned, the independent scalar solver
:mod:`corr_cad.mechanics.reference`, and the textbook sagitta of a circle.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from corr_cad import GearDesign
from corr_cad.geometry.clearance import locus_foot
from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
from corr_cad.mechanics.reference import locus_frame, reference_position
from corr_cad.mechanics.row.solver import solve_forces
from corr_cad.mechanics.row.windup import Windup, crank_angles_of, revolution_classes

ARCMIN = 60.0 * 180.0 / math.pi  # written out: the tests never use the package's conversions
ARCSEC = 60.0 * ARCMIN
M0 = 1.1e5  # N*mm, the prototype's crank moment
T_R = 26 * M0  # N*mm: (z + 1) M0, 2860 N*m
SHARE = 0.55
ROOT = Path(__file__).resolve().parents[1]


# --- closed forms, written out here -------------------------------------------------


def _hand(design: GearDesign, x: float, dr=None) -> dict:
    """Per roller at output angle ``x``: psi, advance a, force ratios, linear compliance.

    psi_i = z x - i 2 pi/(z+1) (crank relative to the frame is z x);
    s = e cos psi + W, W = sqrt(L^2 - e^2 sin^2 psi); moment arm a = -e s sin psi / L;
    the normal leans from the radial by tan(beta) = z e sin psi / W, so
    F_n/F_j = W / (L cos beta) = sqrt(W^2 + z^2 e^2 sin^2 psi) / L;
    |F_s|/F_j = (z + 1) e |sin psi| / L; linear contact 2 F/(pi l E'),
    E' = E / (2 (1 - nu^2)) for the pair.
    """
    z, R = design.tooth_count, design.roller_count
    e, r, Rj = design.eccentricity, design.roller_radius, design.cam_radius
    L = Rj + r
    psi = z * x - np.arange(R) * 2 * math.pi / R
    sp = np.sin(psi)
    W = np.sqrt(L * L - (e * sp) ** 2)
    s = e * np.cos(psi) + W
    rho_n = np.sqrt(W * W + (z * e * sp) ** 2) / L
    rho_s = R * e * np.abs(sp) / L
    E, nu = design.material.young_modulus, design.material.poisson_ratio
    lam = 2.0 / (math.pi * design.roller_length * E / (2 * (1 - nu * nu)))
    out = {"psi": psi, "a": -e * s * sp / L, "rho_n": rho_n, "rho_s": rho_s}
    out["k0"] = lam * (1 + rho_n**2 + rho_s**2)
    if dr is not None:  # uniform roller radius error: g = dr (1 + rho_n) - |rho_s| max(-dr, 0)
        out["g"] = dr * (1 + rho_n) - rho_s * max(-dr, 0.0)
    return out


def _linear_windup(h: dict, T: float, z1: int) -> float:
    """Output windup (rad) with linear contacts by hand: a scalar root of the moment balance."""
    g = h.get("g", np.zeros_like(h["a"]))
    M = -SHARE * T / z1  # the modelled cam's moment for an output torque T

    def moment(tau):
        return float(np.sum(h["a"] * np.maximum(tau * h["a"] + g, 0.0) / h["k0"])) - M

    tau = brentq(moment, -1.0, 1.0, xtol=1e-18, rtol=1e-15)
    return -tau / z1


def _hand_backlash(h: dict, z1: int) -> float:
    a, g = h["a"], h["g"]
    fwd = np.min(-g[a > 1e-12] / a[a > 1e-12])
    rev = np.max(-g[a < -1e-12] / a[a < -1e-12])
    return (fwd - rev) / z1


# --- item 1: the windup primitive ---------------------------------------------------


def test_output_angle_maps_to_crank_angle_z_x(prototype):
    """Output angle x (ring fixed) is crank angle z x relative to the frame.

    Pinned where it matters: a ring deviation dev(t) is read at the roller's
    polar angle on the ring, t = x + i pitch. With one roller radius error
    the only gap of roller 0 is dev(x) rho_n (hand), and the windup's free
    rotation must follow it position by position.
    """
    assert crank_angles_of(np.array([0.01]), prototype)[0] == pytest.approx(0.25, rel=1e-15)
    dev = harmonic_deviation([(7, 0.004, 30.0)])  # mm, moves with the polar angle t
    err = ManufacturingErrors(roller_radius_error=-0.006, profile_deviation=dev)  # all clear
    x = np.radians([0.0, 3.0, 11.0, 40.0, 200.0])
    w = Windup(prototype, x, errors=err)
    lo, hi = w.free_ends()
    for j, xj in enumerate(x):
        h = _hand(prototype, xj, dr=-0.006)
        t = xj + np.arange(26) * 2 * math.pi / 26
        h["g"] = h["g"] + h["rho_n"] * 0.004 * np.cos(7 * t - math.radians(30.0))
        assert np.all(h["g"] < 0)
        a, g = h["a"], h["g"]
        fwd = np.min(-g[a > 1e-12] / a[a > 1e-12])
        rev = np.max(-g[a < -1e-12] / a[a < -1e-12])
        assert hi[j] == pytest.approx(-rev / 26, rel=1e-9)
        assert lo[j] == pytest.approx(-fwd / 26, rel=1e-9)


def test_revolution_classes_equal_solving_every_position(prototype):
    """The transmission error's shortcut (each periodicity class solved once) changes nothing."""
    per = tuple(0.0015 * math.sin(1.3 * i) - 0.003 for i in range(26))
    for err, solved in (
        (ManufacturingErrors(), 12),
        (ManufacturingErrors(roller_radius_errors=per), None),
    ):
        x_solve, index = revolution_classes(prototype, 12, err)
        N = 12 * 26
        assert len(index) == N
        if solved is not None:
            assert len(x_solve) == solved  # 25 k mod 12: every class of a mesh period
        direct = Windup(prototype, 2 * np.pi * np.arange(N) / N, errors=err).theta(0.03 * T_R)
        short = Windup(prototype, x_solve, errors=err).theta(0.03 * T_R)[index]
        np.testing.assert_allclose(short, direct, rtol=1e-12, atol=1e-15)


def test_windup_is_minus_tau_over_z_plus_1_of_the_solver(prototype):
    """theta(T) = -tau / (z + 1) with the cam moment -load_share T / (z + 1)."""
    x = np.radians([0.0, 0.2, 7.7])
    w = Windup(prototype, x)
    for T in (T_R, -0.4 * T_R):
        res = solve_forces(prototype, -T / 26, crank_angles_of(x, prototype), load_share=SHARE)
        np.testing.assert_allclose(w.theta(T), -res.cam_rotation / 26, rtol=1e-10)
        assert np.all(np.sign(w.theta(T)) == np.sign(T))  # turns with the torque


def _chain_overlap(design, Phi: float, X: float, i: int) -> float:
    """Exact cam overlap of roller i resting on the ring in its slot, crank at Phi, frame at X.

    The slot ray at polar angle t = X + i pitch meets the ring's roller-centre
    locus at the radius s(z t) (the roller touches the ring there); the cam
    centre is at e (sin Phi, cos Phi). Overlap = L - |H - O1|.
    """
    z, e, L = design.tooth_count, design.eccentricity, design.link_length
    t = X + i * 2 * math.pi / (z + 1)
    s = locus_frame(t, z, e, L)["s"]
    hx, hy = s * math.sin(t), s * math.cos(t)
    return L - math.hypot(hx - e * math.sin(Phi), hy - e * math.cos(Phi))


def test_reciprocity_crank_locked_windup_is_cam_rotation_over_z_plus_1(prototype):
    """A crank-locked bench built here from exact geometry agrees with the frame-locked solver.

    Per roller, the overlap rate under a frame turn with the crank locked is
    -(z + 1) times the rate under a cam turn with the frame held (exact
    geometry, central differences). The bench's own linear-contact windup,
    T_row = sum F_i rate_i with F_i = rate_i w / k0_i and T_row = share T,
    equals the frame-locked cam rotation over z + 1 and the windup primitive.
    """
    z1 = 26
    h_step = 1e-6
    for x in (0.0, math.radians(0.31), math.radians(17.0)):
        Phi, X = z1 * x, x
        bench = np.array(
            [
                (
                    _chain_overlap(prototype, Phi, X + h_step, i)
                    - _chain_overlap(prototype, Phi, X - h_step, i)
                )
                / (2 * h_step)
                for i in range(z1)
            ]
        )
        cam = np.array(
            [
                (
                    _chain_overlap(prototype, Phi + h_step, X, i)
                    - _chain_overlap(prototype, Phi - h_step, X, i)
                )
                / (2 * h_step)
                for i in range(z1)
            ]
        )
        np.testing.assert_allclose(bench, -z1 * cam, rtol=1e-6, atol=1e-9)
        h = _hand(prototype, x)
        np.testing.assert_allclose(cam, h["a"], rtol=1e-6, atol=1e-9)
        for T in (0.7 * T_R, -0.2 * T_R):
            on = bench * T > 0
            w_bench = SHARE * T / np.sum(bench[on] ** 2 / h["k0"][on])
            res = solve_forces(prototype, -T / z1, np.array([Phi - X]), contact_model="linear")
            w_code = Windup(prototype, np.array([x]), contact_model="linear").theta(T)[0]
            assert -res.cam_rotation[0] / z1 == pytest.approx(w_bench, rel=1e-6)
            assert w_code == pytest.approx(w_bench, rel=1e-6)


def test_rigidity_against_the_linear_contact_closed_form(prototype):
    """Linear contacts, no errors: K = (z + 1)^2 sum a_i^2/k0_i / share over the loaded side."""
    spec = DatasheetSpec(
        rated_torque=T_R, positions_per_mesh=4, transmission_error_positions_per_turn=4
    )
    ds = datasheet(prototype, spec, contact_model="linear")
    rig = ds.rigidity(contact_only=True)  # rows: +T, -T branches, N*m/arcmin
    for j, x in enumerate(ds.output_angles):
        h = _hand(prototype, x)
        for row, side in ((0, h["a"] < 0), (1, h["a"] > 0)):  # T > 0 loads the a < 0 rollers
            K = 26**2 * np.sum(h["a"][side] ** 2 / h["k0"][side]) / SHARE  # N*mm/rad
            assert rig[row, j] == pytest.approx(K / 1000.0 / ARCMIN, rel=1e-9)


def test_rigidity_against_finite_differences_of_the_reference_windup(prototype):
    """The datasheet's secant on [T_1, T_2] is the finite difference of the reference windup."""
    spec = DatasheetSpec(
        rated_torque=T_R, positions_per_mesh=3, transmission_error_positions_per_turn=2
    )
    ds = datasheet(prototype, spec)
    rig = ds.rigidity(contact_only=True)
    for j in (0, 2):
        phi = prototype.tooth_count * ds.output_angles[j]
        theta = {}
        for share in (0.5, 1.0, -0.5, -1.0):
            T = share * T_R
            _, tau = reference_position(prototype, -T / 26, phi, load_share=SHARE)
            theta[share] = -tau / 26
        pos = 0.5 * T_R / 1000.0 / ((theta[1.0] - theta[0.5]) * ARCMIN)
        neg = -0.5 * T_R / 1000.0 / ((theta[-1.0] - theta[-0.5]) * ARCMIN)
        assert rig[0, j] == pytest.approx(pos, rel=1e-7)
        assert rig[1, j] == pytest.approx(neg, rel=1e-7)
        assert 1.5e4 < pos < 3.5e4  # contacts alone: ~20x a catalogue RV-320E (1,176)


def _sag(F: float, k1: float, k2: float, design) -> float:
    """Textbook Hertz approach of two circles (signed curvatures) pressed by F."""
    E, nu = design.material.young_modulus, design.material.poisson_ratio
    Ep = E / (2 * (1 - nu * nu))
    b2 = 4 * F / (math.pi * design.roller_length * Ep * (k1 + k2))
    out = 0.0
    for k in (k1, k2):
        if k != 0.0:
            R = 1.0 / k
            out += math.copysign(abs(R) - math.sqrt(R * R - b2), R)
    return out


def test_virtual_work_torque_times_windup_is_the_contact_work(prototype):
    """share T d(theta) = sum over rollers and contacts of F d(delta), approaches by hand."""
    x = np.array([math.radians(0.13)])
    w = Windup(prototype, x)
    T, dT = 0.6 * T_R, 1e-4 * T_R
    r = prototype.roller_radius
    frame = [
        locus_frame(x[0] + i * 2 * math.pi / 26, 25, prototype.eccentricity, prototype.link_length)
        for i in range(26)
    ]
    k_gear = [-f["curvature"] / (1 + r * f["curvature"]) for f in frame]  # working profile

    mid = w.forces(T)
    lo, hi = w.forces(T - dT), w.forces(T + dT)
    work = 0.0
    for i in range(26):
        for name, k2 in (("F_j", 1 / prototype.cam_radius), ("F_n", k_gear[i]), ("F_s", 0.0)):
            F = abs(getattr(mid, name)[0, i])
            if F > 0:
                d_hi = _sag(abs(getattr(hi, name)[0, i]), 1 / r, k2, prototype)
                d_lo = _sag(abs(getattr(lo, name)[0, i]), 1 / r, k2, prototype)
                work += F * (d_hi - d_lo)
    dtheta = w.theta(T + dT)[0] - w.theta(T - dT)[0]
    assert work > 0
    assert SHARE * T * dtheta == pytest.approx(work, rel=1e-6)


# --- backlash: the windup route against the exact clearance geometry ----------------

PER = tuple(round(0.001 * math.sin(1.7 * i + 0.3), 6) for i in range(26))
SLOTS = tuple(math.radians(0.002 * math.cos(2.1 * i)) for i in range(26))
MIXED = ManufacturingErrors(
    cam_radius_error=-0.001,
    eccentricity_error=0.0015,
    roller_radius_error=-0.003,
    roller_radius_errors=PER,
    slot_angle_errors=SLOTS,
    cam_phase_error=math.radians(0.01),
    profile_deviation=harmonic_deviation([(3, 0.0005, 40.0)]),
)


def _exact_margin(design, err: ManufacturingErrors, x: float, w: float) -> float:
    """Smallest free radial play of any roller, mm: crank locked at (z+1) x, frame at x + w.

    Roller i may sit anywhere in its (turned) slot of width 2 r: lateral
    offset u within +-(r - r_i). Along the slot line it clears the cam from
    s_cam(u) on (circle of radius Rc + r_i about the moved cam centre, closed
    form) and the ring up to s_ring(u), where the exact clearance stage's
    distance to the ring (:func:`locus_foot`, less the deviation at the foot)
    equals r_i. Its play is the best u's s_ring - s_cam.
    """
    z, R = design.tooth_count, design.roller_count
    r, Rc = design.roller_radius, design.cam_radius + err.cam_radius_error
    Phi = R * x + err.cam_phase_error
    ec = design.eccentricity + err.eccentricity_error
    ox, oy = ec * math.sin(Phi), ec * math.cos(Phi)
    dev = err.profile_deviation
    worst = math.inf
    for i in range(R):
        ri = r + err.roller_radius_error + (err.roller_radius_errors or (0.0,) * R)[i]
        a = x + w + i * 2 * math.pi / R + (err.slot_angle_errors or (0.0,) * R)[i]
        ur, ut = (math.sin(a), math.cos(a)), (math.cos(a), -math.sin(a))
        o_r, o_t = ox * ur[0] + oy * ur[1], ox * ut[0] + oy * ut[1]
        s0 = locus_frame(a, z, design.eccentricity, design.link_length)["s"]
        c = max(r - ri, 0.0)
        best = -math.inf
        for u in np.linspace(-c, c, 5):
            s_cam = o_r + math.sqrt((Rc + ri) ** 2 - (u - o_t) ** 2)

            def ring(s, u=u, ur=ur, ut=ut, ri=ri):
                q = np.array([[s * ur[0] + u * ut[0], s * ur[1] + u * ut[1]]])
                t, off = locus_foot(design, q)
                d = r - off[0] - (dev(t)[0] if dev is not None else 0.0)
                return d - ri

            s_ring = brentq(ring, s0 - 0.05, s0 + 0.05, xtol=1e-13, rtol=1e-15)
            best = max(best, s_ring - s_cam)
        worst = min(worst, best)
    return worst


@pytest.mark.slow
def test_backlash_equals_the_exact_free_rotation_of_the_clearance_geometry(prototype):
    """Free rotation with the crank locked, from the exact distances, to 1e-3 arcmin.

    Every error kind at once (all in clearance). The windup route: the gap
    path of the datasheet and theta(+eps) - theta(-eps) from force solves.
    """
    x = np.radians([0.05, 7.3, 123.0])
    w = Windup(prototype, x, errors=MIXED)
    gap_route = w.backlash() * ARCMIN
    eps = 1e-6 * T_R
    solve_route = (w.theta(eps) - w.theta(-eps)) * ARCMIN
    for j, xj in enumerate(x):
        assert _exact_margin(prototype, MIXED, xj, 0.0) > 0  # free at the kinematic position
        hi = brentq(lambda v, xj=xj: _exact_margin(prototype, MIXED, xj, v), 0.0, 1e-3, xtol=1e-12)
        lo = brentq(lambda v, xj=xj: _exact_margin(prototype, MIXED, xj, v), -1e-3, 0.0, xtol=1e-12)
        exact = (hi - lo) * ARCMIN
        assert exact > 0.3  # a real play
        assert gap_route[j] == pytest.approx(exact, abs=1e-3)
        assert solve_route[j] == pytest.approx(exact, abs=1e-3)
        # The ends too: theta(0+) is where the frame stops turning forwards.
        assert w.free_ends()[1][j] * ARCMIN == pytest.approx(hi * ARCMIN, abs=1e-3)


def test_two_micrometre_undersize_backlash_and_lost_motion_by_hand(prototype):
    """All rollers 2 um undersize: backlash by hand, and lost motion with linear contacts."""
    err = ManufacturingErrors(roller_radius_error=-0.002)
    spec = DatasheetSpec(
        rated_torque=T_R, positions_per_mesh=3, transmission_error_positions_per_turn=2
    )
    ds = datasheet(prototype, spec, errors=err, contact_model="linear")
    for j, x in enumerate(ds.output_angles):
        h = _hand(prototype, x, dr=-0.002)
        backlash = _hand_backlash(h, 26)
        assert ds.backlash()[j] == pytest.approx(backlash, rel=1e-9)
        lm = _linear_windup(h, 0.03 * T_R, 26) - _linear_windup(h, -0.03 * T_R, 26)
        assert ds.lost_motion()[j] == pytest.approx(lm, rel=1e-9)
        assert (
            0.4 < backlash * ARCMIN < 0.45 and lm > backlash
        )  # 0.425 arcmin; plus the elastic part


def test_one_roller_oversize_transmission_error_has_a_feature_each_pass(prototype):
    """A set ground 5 um undersize, one roller 5 um larger than the rest.

    Forward (the load resists + rotation, T = -T_TE) rollers with a > 0, i.e.
    sin(psi) < 0, carry. Wherever roller 0 is outside that zone the
    transmission error is that of the set without it (exactly flat, as
    there); each time it passes through the zone it pushes the output
    ahead by micrometres / arm: z = 25 features per output revolution.
    """
    per = (0.005,) + (0.0,) * 25
    base = ManufacturingErrors(roller_radius_error=-0.005)
    odd = ManufacturingErrors(roller_radius_error=-0.005, roller_radius_errors=per)
    spec = DatasheetSpec(
        rated_torque=T_R, positions_per_mesh=2, transmission_error_positions_per_turn=72
    )
    ref = datasheet(prototype, spec, errors=base)
    ds = datasheet(prototype, spec, errors=odd)
    x = ds.te_output_angles
    psi0 = np.mod(25 * x, 2 * math.pi)  # roller 0: psi = z x
    for te, te_ref, zone in (
        (ds.te_forward, ref.te_forward, np.sin(psi0) < 0),
        (ds.te_reverse, ref.te_reverse, np.sin(psi0) > 0),
    ):
        diff = np.abs(te - te_ref) * ARCSEC
        assert np.all(diff[~zone] < 1e-9)  # flat elsewhere: the set's own curve
        assert np.ptp(te_ref) * ARCSEC < 0.1  # ... which is flat
        core = np.abs(np.sin(psi0)) > 0.5
        assert np.all(diff[zone & core] > 5.0)  # arcsec: the feature
        feature = (diff > 1.0).astype(int)
        starts = np.count_nonzero(np.diff(np.concatenate([feature, feature[:1]])) == 1)
        assert starts == 25  # every pass of roller 0 through the loaded zone


def test_series_compliance_adds_T_over_K(prototype):
    spec = DatasheetSpec(
        rated_torque=T_R,
        positions_per_mesh=2,
        transmission_error_positions_per_turn=2,
        series_rigidity_Nm_per_arcmin=1200.0,
    )
    ds = datasheet(prototype, spec)
    added = ds.torques / 1000.0 / 1200.0 / ARCMIN  # rad: T [N*m] / K [N*m/arcmin], in rad
    np.testing.assert_allclose(
        ds.windup - ds.contact_windup, added[:, None] + 0 * ds.windup, atol=1e-15
    )
    c, k = ds.rigidity(contact_only=True), ds.rigidity()
    np.testing.assert_allclose(1 / k, 1 / c + 1 / 1200.0, rtol=1e-9)
    # The series compliance adds nothing at zero torque: the backlash is the contacts'.
    np.testing.assert_array_equal(ds.backlash(), ds.at(0.0, True) - ds.at(-0.0, True))


def test_rated_torque_from_contact_pressure_reaches_the_allowable(prototype):
    spec = DatasheetSpec(
        rated_torque=T_R,
        positions_per_mesh=4,
        transmission_error_positions_per_turn=2,
        allowable_contact_pressure=1500.0,
    )
    ds = datasheet(prototype, spec)
    T = ds.rated_from_pressure["torque_Nm"] * 1000.0
    angles = 25 * ds.output_angles
    for factor, above in ((1.0, None), (0.99, False), (1.01, True)):
        res = solve_forces(prototype, factor * T / 26, angles, load_share=SHARE)
        p = max(res.p_cam.max(), res.p_slot.max(), res.p_gear.max())
        if above is None:
            assert p == pytest.approx(1500.0, rel=1e-5)
        else:
            assert (p > 1500.0) == above


def test_rated_torque_from_pressure_is_the_weaker_direction(prototype):
    """Rollers of three undersizes: the two directions reach the allowable at different
    torques (2268 and 2275 N*m); the figure is the smaller, checked by direct solves."""
    dr = tuple(-0.001 - 0.001 * (np.arange(26) % 3))
    err = ManufacturingErrors(roller_radius_errors=dr)
    spec = DatasheetSpec(
        rated_torque=T_R,
        positions_per_mesh=4,
        transmission_error_positions_per_turn=2,
        allowable_contact_pressure=1500.0,
    )
    ds = datasheet(prototype, spec, errors=err)
    r = ds.rated_from_pressure
    assert abs(r["positive_Nm"] - r["negative_Nm"]) > 1e-3 * r["torque_Nm"]
    T = r["torque_Nm"] * 1000.0  # N*mm
    angles = 25 * ds.output_angles

    def peak(torque):
        res = solve_forces(prototype, torque / 26, angles, load_share=SHARE, errors=err)
        return max(res.p_cam.max(), res.p_slot.max(), res.p_gear.max())

    # At the figure, one direction is at the allowable and neither is above it.
    both = [peak(T), peak(-T)]
    assert max(both) == pytest.approx(1500.0, rel=1e-5)
    assert peak(0.999 * T) < 1500.0 and peak(-0.999 * T) < 1500.0


@pytest.mark.parametrize(
    "errors,variants,period",
    [
        ({}, (), 2 * math.pi / (25 * 26)),
        ({"roller_radius_error": -0.002, "cam_phase_error": 0.01}, (), 2 * math.pi / (25 * 26)),
        ({"roller_radius_errors": (0.001,) + (0.0,) * 25}, (), 2 * math.pi / 25),
        ({"slot_angle_errors": (0.0,) * 25 + (0.002,)}, (), 2 * math.pi / 25),
        ({}, ("eq3_printed",), 2 * math.pi / 25),
        ({"profile_harmonics": ((3, 0.002, 0.0),)}, (), 2 * math.pi),
    ],
    ids=["nominal", "alike", "one_roller", "one_slot", "eq3_printed", "ring_harmonic"],
)
def test_the_windup_repeats_after_the_period_of_its_errors(prototype, errors, variants, period):
    """Mesh period 2 pi / (z (z + 1)) while rollers and slots are alike, a tooth pitch
    2 pi / z once one differs, a revolution with a ring deviation (written out)."""
    from corr_cad.mechanics.row.windup import result_period_rad

    if "profile_harmonics" in errors:
        err = ManufacturingErrors(profile_deviation=harmonic_deviation(errors["profile_harmonics"]))
    else:
        err = ManufacturingErrors(**errors)
    assert result_period_rad(prototype, err, variants) == pytest.approx(period, rel=1e-15)


# --- the files: every figure again from the CSV files, by hand ----------------------


def _run(tmp_path, text: str, name: str = "ds"):
    scene = tmp_path / f"{name}.toml"
    scene.write_text(text)
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(tmp_path / name)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )


SCENE = """
[export]
formats = ["datasheet", "report"]
[load]
input_torque = 1.1e5
[errors]
roller_radius_error = -0.002
[datasheet]
positions_per_mesh = 4
transmission_error_positions_per_turn = 36
series_rigidity_Nm_per_arcmin = 1200.0
[checks]
max_lost_motion_arcmin = 1.0
max_backlash_arcmin = 1.0
min_torsional_rigidity_Nm_per_arcmin = 1000.0
max_transmission_error_arcsec = 60.0
"""


#: Formulas the page quotes whose constants are no figures (left out of the sentence check).
SENTENCE_FORMULAS = ("z + 1", "1 - losses", "3.84e-5 Q^0.9 / l^0.8", "0 -> +T_R -> 0 -> -T_R -> 0")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("datasheet")
    r = _run(tmp, SCENE)
    assert r.returncode == 0, r.stderr
    return tmp / "ds", r


def test_datasheet_html_is_written_and_its_numbers_are_datasheet_json_s(run_dir):
    """datasheet.html beside datasheet.json: every figure cell holds the JSON's exact value
    (data-value) and shows it rounded to 4 significant digits, never in e-notation; the two
    curves are embedded byte for byte; the model is named."""
    import base64

    from tests.page_check import (
        Page,
        check_cells,
        check_every_number_is_a_cell,
        check_sentence_numbers,
    )

    out, r = run_dir
    sheet = json.loads((out / "datasheet.json").read_text())
    text = (out / "datasheet.html").read_text()
    assert "datasheet.html" in json.loads((out / "manifest.json").read_text())["files"]
    p = Page(text)
    keys = check_cells(p, sheet)
    assert {
        "rated_torque_Nm",
        "backlash_arcmin.max",
        "lost_motion_arcmin.max",
        "torsional_rigidity_Nm_per_arcmin.headline",
        "torsional_rigidity_Nm_per_arcmin.contact_only.min",
        "stiffness_Nm_per_arcmin.K1.min",
        "transmission_error_arcsec.catalogue",
    } <= keys
    check_every_number_is_a_cell(p, sheet)  # every number of datasheet.json, by its key
    # the numbers inside sentences (conventions, model, notes) are datasheet.json's too
    design = (25, 26, 135, 8, 3.5, 12, 0.55)
    assert check_sentence_numbers(p, sheet, design, SENTENCE_FORMULAS) > 10
    assert sheet["rated_torque_Nm"] == 2860.0 and "2,860" in text  # catalogue form
    # The curves: the run's own PNGs, embedded.
    for name in ("hysteresis.png", "transmission_error.png"):
        data = "data:image/png;base64," + base64.b64encode((out / name).read_bytes()).decode()
        assert data in p.imgs, name
    for words in (
        "Hertz line contacts (nonlinear)",
        "frictionless",
        "one row carrying a load share 0.55",
    ):
        assert words in text


@pytest.mark.slow
def test_figures_are_reproducible_by_hand_from_the_csv_files(run_dir, prototype):
    out, _ = run_dir
    d = json.loads((out / "datasheet.json").read_text())
    rows = np.genfromtxt(out / "windup.csv", delimiter=",", names=True)
    assert d["rated_torque_Nm"] == pytest.approx(2860.0, rel=1e-15)  # 26 x 110 N*m
    angles = np.unique(rows["output_angle_deg"])
    assert len(angles) == d["positions"]["count"] == 4
    bl, lm, rig, k1 = [], [], [], []
    for a in angles:
        c = rows[rows["output_angle_deg"] == a]
        T, th = c["output_torque_Nm"], c["windup_arcmin"]
        assert np.all(np.diff(T) >= 0)
        z = np.flatnonzero(T == 0)
        assert len(z) == 2 and np.signbit(T[z[0]]) and not np.signbit(T[z[1]])  # "-0", then "0"
        bl.append(th[z[1]] - th[z[0]])

        def at(v, T=T, th=th):
            return th[np.flatnonzero(np.isclose(T, v, rtol=1e-12, atol=0))[0]]

        lm.append(at(85.8) - at(-85.8))
        rig += [1430.0 / (at(2860.0) - at(1430.0)), -1430.0 / (at(-2860.0) - at(-1430.0))]
        k1 += [715.0 / (at(715.0) - th[z[1]]), -715.0 / (at(-715.0) - th[z[0]])]
    for got, want in (
        (d["backlash_arcmin"], bl),
        (d["lost_motion_arcmin"], lm),
        (d["torsional_rigidity_Nm_per_arcmin"]["with_series"], rig),
        (d["stiffness_Nm_per_arcmin"]["K1"], k1),
    ):
        for stat, f in (("min", np.min), ("mean", np.mean), ("max", np.max)):
            assert got[stat] == pytest.approx(f(want), rel=1e-9)
    contact = 1 / (1 / np.array(rig) - 1 / 1200.0)
    assert d["torsional_rigidity_Nm_per_arcmin"]["contact_only"]["min"] == pytest.approx(
        contact.min(), rel=1e-7
    )
    te = np.genfromtxt(out / "transmission_error.csv", delimiter=",", names=True)
    assert len(te) == 36 * 26
    assert te["output_angle_deg"][-1] == pytest.approx(360.0 * (1 - 1 / 936), rel=1e-9)
    t = d["transmission_error_arcsec"]
    assert t["forward_peak_to_peak"] == pytest.approx(np.ptp(te["forward_arcsec"]), abs=1e-9)
    assert t["reverse_peak_to_peak"] == pytest.approx(np.ptp(te["reverse_arcsec"]), abs=1e-9)
    # The forward curve lags (negative), the reverse leads: the backlash splits them.
    assert np.all(te["forward_arcsec"] < 0) and np.all(te["reverse_arcsec"] > 0)
    assert d["hysteresis_loss_arcmin"] == 0.0 and "friction" in d["hysteresis_loss_note"]
    # Backlash by hand from the closed forms, at the CSV's own positions.
    for a, b in zip(angles, bl, strict=True):
        h = _hand(prototype, math.radians(a), dr=-0.002)
        assert b == pytest.approx(_hand_backlash(h, 26) * ARCMIN, rel=1e-9)


@pytest.mark.slow
def test_checks_console_and_report_show_the_datasheet(run_dir):
    out, r = run_dir
    m = json.loads((out / "manifest.json").read_text())
    d = json.loads((out / "datasheet.json").read_text())
    c = m["checks"]
    assert c["max_lost_motion_arcmin"]["value"] == pytest.approx(d["lost_motion_arcmin"]["max"])
    rig = d["torsional_rigidity_Nm_per_arcmin"]["with_series"]["min"]
    assert c["min_torsional_rigidity_Nm_per_arcmin"]["value"] == pytest.approx(rig)
    te = d["transmission_error_arcsec"]
    assert c["max_transmission_error_arcsec"]["value"] == pytest.approx(
        max(te["forward_peak_to_peak"], te["reverse_peak_to_peak"])
    )
    assert 0.4 < c["max_backlash_arcmin"]["value"] < c["max_lost_motion_arcmin"]["value"]
    assert "datasheet at T_R = 2,860 N*m" in r.stdout
    assert "rigidity, contacts" in r.stdout and "series 1,200 included" in r.stdout
    assert "warning" not in r.stderr  # a scene with [datasheet] is not warned about the rename
    html = (out / "report.html").read_text()
    assert 'id="datasheet"' in html and "torsional rigidity, contacts alone" in html
    for name in ("datasheet.json", "windup.csv", "transmission_error.csv", "hysteresis.png"):
        assert name in m["files"]


# --- item 3: the old key, and bad input ---------------------------------------------


def test_old_lost_motion_key_keeps_working_with_one_warning(tmp_path):
    r = _run(
        tmp_path,
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n[solver]\npositions = 52\n'
        "[errors]\nroller_radius_error = -0.002\n[checks]\nmax_lost_motion_arcmin = 0.44\n",
    )
    warned = [ln for ln in r.stderr.splitlines() if "warning" in ln]
    assert len(warned) == 1 and "max_lost_motion_arcmin" in warned[0]
    assert "max_backlash_arcmin" in warned[0]
    # The new meaning: 0.448 arcmin of lost motion fails a limit the 0.425 backlash passed.
    assert r.returncode == 1, r.stderr
    m = json.loads((tmp_path / "ds" / "manifest.json").read_text())
    assert 0.44 < m["checks"]["max_lost_motion_arcmin"]["value"] < 0.46


@pytest.mark.parametrize(
    "section, want",
    [
        (
            "[datasheet]\nlost_motion_band = 1.5\n",
            "[datasheet] lost_motion_band = 1.5: allowed range is [0.001, 1), e.g. 0.03",
        ),
        (
            "[datasheet]\npositions_per_mesh = 0\n",
            "[datasheet] positions_per_mesh = 0: allowed range is (0, 10000], e.g. 16",
        ),
        (
            "[datasheet]\nrigidity_range = [1.0, 0.5]\n",
            "[datasheet] rigidity_range = [1.0, 0.5]: must be [T_1, T_2] with "
            "0 <= T_1 < T_2 <= 1 (shares of T_R), T_2 - T_1 >= 0.001, e.g. [0.5, 1.0]",
        ),
        (
            "[datasheet]\nseries_rigidity_Nm_per_arcmin = -3.0\n",
            "[datasheet] series_rigidity_Nm_per_arcmin = -3: allowed range is (0, 1e+09], "
            "e.g. 1000",
        ),
    ],
)
def test_bad_datasheet_input_is_one_line_and_exit_2(tmp_path, section, want):
    r = _run(
        tmp_path, '[export]\nformats = ["datasheet"]\n[load]\ninput_torque = 1.1e5\n' + section
    )
    assert r.returncode == 2
    assert r.stderr.strip().splitlines()[-1].endswith(want), r.stderr


@pytest.mark.slow
def test_datasheet_needs_a_rated_torque_and_lost_motion_gates_the_montecarlo(tmp_path):
    r = _run(tmp_path, '[export]\nformats = ["datasheet"]\n')
    assert r.returncode == 2 and "rated_torque_Nm is not set" in r.stderr
    # The Monte Carlo computes the lost motion now (tests/test_mc_datasheet.py): the
    # old key with a gate runs, gates the catalogue lost motion and warns once.
    r = _run(
        tmp_path,
        '[export]\nformats = ["forces", "montecarlo"]\n[load]\ninput_torque = 1.1e5\n'
        "[tolerances]\nroller_radius = { normal = 0.001 }\n"
        "[montecarlo]\nsamples = 10\npositions = 12\n[datasheet]\npositions_per_mesh = 1\n"
        "[checks]\nmax_lost_motion_arcmin = 1.0\nmax_failure_probability = 0.05\n",
    )
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "ds" / "manifest.json").read_text())
    assert m["checks"]["montecarlo"]["max_lost_motion_arcmin"]["passed"]
    # Without [load]: T_R from the key alone (N*m), no force solve needed.
    r = _run(
        tmp_path,
        '[export]\nformats = ["datasheet"]\n[datasheet]\nrated_torque_Nm = 1000.0\n'
        "positions_per_mesh = 2\ntransmission_error_positions_per_turn = 4\n",
    )
    assert r.returncode == 0, r.stderr
    d = json.loads((tmp_path / "ds" / "datasheet.json").read_text())
    assert (
        d["rated_torque_Nm"] == 1000.0 and d["rated_torque_source"] == "[datasheet] rated_torque_Nm"
    )


def test_scenes_without_the_datasheet_are_unchanged_and_a_lone_section_warns():
    from corr_cad.run.scene.scene import parse_scene

    forces = {"export": {"formats": ["forces"]}, "load": {"input_torque": M0}}
    sc = parse_scene(forces)
    assert "datasheet" not in sc.source  # manifest.json's inputs stay as they were
    assert not sc.warnings
    sc = parse_scene({**forces, "datasheet": {"positions_per_mesh": 4}})
    assert any(w.startswith("[datasheet] has no effect") for w in sc.warnings)
    sc = parse_scene({**forces, "checks": {"max_transmission_error_arcsec": 5.0}})
    assert "datasheet" in sc.source and not sc.warnings  # the check runs the datasheet
    # A Monte Carlo takes its datasheet metrics' bands from [datasheet]: no warning.
    mc = {
        "export": {"formats": ["montecarlo"]},
        "load": {"input_torque": M0},
        "tolerances": {"roller_radius": {"uniform": 0.001}},
        "datasheet": {"lost_motion_band": 0.03},
    }
    sc = parse_scene(mc)
    assert "datasheet" in sc.source and not sc.warnings


def test_rigidity_range_off_the_torque_grid(prototype):
    spec = DatasheetSpec(
        rated_torque=T_R,
        rigidity_range=(1 / 3, 0.9),
        lost_motion_band=0.04,
        positions_per_mesh=2,
        transmission_error_positions_per_turn=2,
    )
    ds = datasheet(prototype, spec)
    th = ds.windup[:, 0]
    T = ds.torques
    i1 = np.argmin(np.abs(T - T_R / 3))
    i2 = np.argmin(np.abs(T - 0.9 * T_R))
    want = (T[i2] - T[i1]) / 1000.0 / ((th[i2] - th[i1]) * ARCMIN)
    assert ds.rigidity()[0, 0] == pytest.approx(want, rel=1e-12)
    assert np.count_nonzero(np.isclose(np.abs(T), 0.04 * T_R)) == 2
