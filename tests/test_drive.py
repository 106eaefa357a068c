"""The two-row drive (``[solver] model = "drive"``): shares, bearings, equilibrium, clearance."""

import math

import numpy as np
import pytest
from scipy import optimize, special

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors as ME
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive.drive import solve_drive
from corr_cad.mechanics.drive.drive_windup import DriveWindup
from corr_cad.mechanics.reference import reference_geometry
from corr_cad.mechanics.row.solver import solve_forces
from corr_cad.mechanics.row.windup import Windup

T_R = 2.86e6  # N*mm, the prototype's rated output torque
M0 = T_R / 26  # its crank moment
NEEDLES = EccentricBearing(40, 6.0, 12.0)


@pytest.mark.parametrize("law", ["nonlinear", "palmgren"])
def test_nominal_share_is_one_half_when_z_plus_1_is_even(law):
    angles = np.radians(np.linspace(0.0, 360.0 / 26, 7))
    for torque in (0.03 * M0, M0, -0.5 * M0):
        for bearing in (None, NEEDLES):
            res = solve_drive(GearDesign(), torque, angles, contact_model=law, bearing=bearing)
            assert res.success
            np.testing.assert_allclose(res.row_a_share, 0.5, atol=1e-12)


def test_odd_roller_count_ripples_within_the_derived_bound():
    """With z + 1 odd, row B sits half a pitch off row A. With linear contacts each row's
    moment is ``k(phi) tau`` (nominal: every loaded roller touches at tau = 0), so the share
    is exactly ``k(phi) / (k(phi) + k(phi + pi))``, within ``0.5 +- (k_max - k_min) /
    (2 (k_max + k_min))``; ``k`` comes from one-row solves (load_share 1)."""
    design = GearDesign(tooth_count=24, eccentricity=3.5, cam_radius=135.0, roller_radius=8.0)
    assert design.roller_count % 2 == 1
    angles = np.radians(np.linspace(0.0, 360.0 / 25, 9))
    res = solve_drive(design, M0, angles, contact_model="linear")
    k_a = M0 / solve_forces(design, M0, angles, load_share=1.0, contact_model="linear").cam_rotation
    k_b = (
        M0
        / solve_forces(
            design, M0, angles + np.pi, load_share=1.0, contact_model="linear"
        ).cam_rotation
    )
    np.testing.assert_allclose(res.row_a_share, k_a / (k_a + k_b), rtol=1e-10)
    k = np.concatenate([k_a, k_b])
    bound = (k.max() - k.min()) / (2 * (k.max() + k.min()))
    assert np.all(np.abs(res.row_a_share - 0.5) <= bound * (1 + 1e-9))
    assert np.ptp(res.row_a_share) > 0  # it does ripple


@pytest.mark.parametrize("law", ["nonlinear", "palmgren"])
def test_identical_rigid_rows_agree_with_the_paper_model_at_share_one_half(law):
    x = np.radians([0.0, 0.05, 0.2])
    drive = DriveWindup(GearDesign(), x, contact_model=law)
    paper = Windup(GearDesign(), x, load_share=0.5, contact_model=law)
    for T in (0.03 * T_R, T_R, -0.6 * T_R):
        np.testing.assert_allclose(drive.theta(T), paper.theta(T), rtol=1e-9)


def _independent_share(design, errors_a, errors_b, crank_angle, M):
    """Both rows from the reference geometry (imports nothing of the package), each roller's
    force from its own three contacts (paper law, Eqs. 9-12 by sagittas), bisection on the
    shared crank rotation."""
    length = design.roller_length
    E, nu = design.material.young_modulus, design.material.poisson_ratio
    Ep = E / (2 * (1 - nu * nu))

    def sag(b2, k):
        if k == 0.0:
            return 0.0
        R = 1.0 / k
        return math.copysign(abs(R) - math.sqrt(R * R - b2), R)

    def delta(F, k1, k2):
        return (
            0.0
            if F <= 0
            else sag(4 * F / (math.pi * length * Ep * (k1 + k2)), k1)
            + sag(4 * F / (math.pi * length * Ep * (k1 + k2)), k2)
        )

    rows = []
    for errs, phi in ((errors_a, crank_angle), (errors_b, crank_angle + math.pi)):
        k_cam = 1.0 / (design.cam_radius + errs.cam_radius_error)
        rows.append((reference_geometry(design, phi, errs), k_cam))

    def force(tau, g, k_cam):
        k_r = 1.0 / g["r_i"]
        n, ut, c = g["n"], g["ut"], g["c"]

        def residual(Fj):
            Fn, Ft = g["fn"] * Fj, g["ft"] * Fj
            a_n = delta(Fn, k_r, g["k_gear"]) - g["g_n"]
            a_t = -math.copysign(g["clr"] + delta(abs(Ft), k_r, 0.0), Ft) if Ft else 0.0
            det = n[0] * ut[1] - n[1] * ut[0]
            d = ((a_n * ut[1] - n[1] * a_t) / det, (n[0] * a_t - a_n * ut[0]) / det)
            overlap = g["g_j"] + tau * g["advance"] - (d[0] * c[0] + d[1] * c[1])
            return delta(Fj, k_r, k_cam) - overlap

        if residual(0.0) >= 0 or residual(1e-300) >= 0:
            return 0.0
        return optimize.brentq(residual, 0.0, 3e4, xtol=1e-300, rtol=1e-15, maxiter=500)

    def moments(tau):
        out = []
        for geo, k_cam in rows:
            m = 0.0
            for g in geo:
                F = force(tau, g, k_cam)
                o1, c = g["o1"], g["c"]
                m += o1[0] * (-F * c[1]) - o1[1] * (-F * c[0])
            out.append(m)
        return out

    tau = optimize.brentq(
        lambda t: sum(moments(t)) - M, -0.01, 0.01, xtol=1e-300, rtol=1e-15, maxiter=500
    )
    ma, mb = moments(tau)
    return ma / (ma + mb)


def test_share_with_small_rollers_against_an_independent_solve():
    design = GearDesign()
    small = ME(roller_radius_error=-0.001)
    angles = np.radians([0.0, 4.0, 11.0])
    res = solve_drive(design, M0, angles, errors=small, errors_b=ME())
    for p, phi in enumerate(angles):
        ref = _independent_share(design, small, ME(), float(phi), M0)
        assert res.row_a_share[p] == pytest.approx(ref, abs=1e-6)
    # The measured gap: about 0.22 of M0 on rigid cams at T_R (DRIVE-NOTES).
    assert 0.18 < res.row_a_share.mean() < 0.26


def test_small_rollers_share_more_with_floating_cams_and_nothing_at_part_load():
    design, small = GearDesign(), ME(roller_radius_error=-0.001)
    angles = np.radians([0.0, 6.0])
    rigid = solve_drive(design, M0, angles, errors=small, errors_b=ME())
    floating = solve_drive(design, M0, angles, errors=small, errors_b=ME(), bearing=NEEDLES)
    assert np.all(floating.row_a_share > rigid.row_a_share)
    assert 0.36 < floating.row_a_share.mean() < 0.46
    light = solve_drive(design, 0.03 * M0, angles, errors=small, errors_b=ME())
    np.testing.assert_allclose(light.row_a_share, 0.0, atol=1e-12)


def test_needle_bearing_against_stribeck_with_many_needles():
    """Zero clearance, Z -> large: Q_max = F_r / (Z J), J = (1/2pi) int cos^(1+10/9) over the
    loaded half (Harris & Kotzalas, Rolling Bearing Analysis, Ch. 7: J_r(0.5) = 0.2453 for
    line contact, i.e. Stribeck's 4.08 = 1/0.2453 to its three printed digits: the
    tolerance is that rounding, 0.005/4.08 = 1.2e-3, plus the finite Z)."""
    p = 1.0 + 1.0 / 0.9
    J = math.sqrt(math.pi) * special.gamma((p + 1) / 2) / special.gamma(p / 2 + 1) / (2 * math.pi)
    assert 1 / J == pytest.approx(4.08, abs=0.005)
    many = EccentricBearing(720, 3.0, 12.0)
    res = solve_drive(GearDesign(), M0, np.radians([0.0, 3.3]), bearing=many)
    for c in (0, 1):
        F_r = res.bearing_load[c]
        np.testing.assert_allclose(res.needle_load_max[c], F_r / (720 * J), rtol=2e-4)
        np.testing.assert_allclose(res.needle_load_max[c], 4.08 * F_r / 720, rtol=2e-3)


@pytest.mark.parametrize("law", ["nonlinear", "palmgren"])
def test_equilibrium_of_every_cam_and_the_crank(law):
    design = GearDesign()
    errs = ME(roller_radius_errors=tuple(1e-3 * np.sin(np.arange(26))), cam_phase_error=1e-4)
    b2 = EccentricBearing(36, 5.0, 10.0, 0.004)
    angles = np.radians(np.linspace(0, 30, 11))
    res = solve_drive(
        design, M0, angles, errors=errs, contact_model=law, bearing=NEEDLES, bearing_b=b2
    )
    assert res.success
    e, L = design.eccentricity, design.cam_radius + design.roller_radius
    moment = 0.0
    for c, bearing in enumerate((NEEDLES, b2)):
        row = res.rows[c]
        psi = row.psi
        s = e * np.cos(psi) + np.sqrt(L**2 - (e * np.sin(psi)) ** 2)  # crank-slider
        n = np.stack([-s * np.sin(psi) / L, (s * np.cos(psi) - e) / L], axis=-1)
        push = np.einsum("pk,pkx->px", row.F_j, n)
        a = 2 * np.pi * np.arange(bearing.needles) / bearing.needles
        ej = np.stack([np.sin(a), np.cos(a)], axis=1)
        carried = res.needle_loads[c] @ ej
        scale = np.sum(row.F_j, axis=1)[:, None]
        assert np.all(np.abs(carried - push) <= 1e-9 * scale)
        np.testing.assert_allclose(np.linalg.norm(push, axis=1), res.bearing_load[c], rtol=1e-12)
        moment = moment + np.sum(row.geometry.arm * row.F_j, axis=1)
    np.testing.assert_allclose(moment, M0, rtol=1e-9)
    assert np.all(res.needle_load_max >= 0)


def test_cam_b_bearing_carries_its_rollers_resultant():
    b2 = EccentricBearing(36, 5.0, 10.0, 0.004)
    angles = np.radians([0.0, 2.0])
    res = solve_drive(GearDesign(), M0, angles, bearing=NEEDLES, bearing_b=b2)
    # Cam B's needles: the loads of its own bearing (largest from the Stribeck estimate's range).
    ratio = res.needle_load_max[1] / (res.bearing_load[1] / 36)
    assert np.all((4.0 < ratio) & (ratio < 7.0))  # clearance concentrates the load above 4.08


def test_bearing_clearance_adds_lost_motion_within_the_hand_bound():
    """A cam centre shift u acts like a crank rotation u_x / e (u_x across the eccentric):
    a diametral clearance Pd lets each cam shift Pd/2 either way, so the nominal drive's
    free rotation is exactly Pd / (e (z + 1)) of output. At +-3 % T_R the lost motion grows
    by that plus the bearing's softer elastic part: its approach is at most that of one
    needle carrying the whole radial load F_r (the fewest needles, the softest bearing),
    delta_1 = 2 c F_r^0.9 / cos(pi / Z), once per direction."""
    design = GearDesign()
    Pd = 0.01
    x = np.radians([0.0, 0.1])
    loose_bearing = EccentricBearing(40, 6.0, 12.0, Pd)
    tight = DriveWindup(design, x, bearing=NEEDLES)
    loose = DriveWindup(design, x, bearing=loose_bearing)
    ratio = design.eccentricity * design.roller_count
    free = Pd / ratio
    assert np.all(tight.backlash() == 0.0)
    np.testing.assert_allclose(loose.backlash(), free, rtol=1e-6)
    T = 0.03 * T_R
    added = (loose.theta(T) - loose.theta(-T)) - (tight.theta(T) - tight.theta(-T))
    F_r = loose.forces(T).bearing_load.max(axis=0)
    c = 2 * 3.84e-5 / loose_bearing.needle_length**0.8  # two raceways, Palmgren
    delta_1 = c * F_r**0.9 / math.cos(math.pi / loose_bearing.needles)
    assert np.all(added >= free * (1 - 1e-6))
    assert np.all(added <= free + 2 * delta_1 / ratio)


def test_cam_phase_error_moves_the_share_antisymmetrically():
    angles = np.radians([0.0, 5.0, 9.0])
    d = math.radians(0.01)
    plus = solve_drive(GearDesign(), M0, angles, errors=ME(cam_phase_error=d))
    minus = solve_drive(GearDesign(), M0, angles, errors=ME(cam_phase_error=-d))
    np.testing.assert_allclose(plus.row_a_share - 0.5, -(minus.row_a_share - 0.5), atol=1e-6)
    # Cam B leads: it meets its rollers first under a positive crank moment (documented sign).
    assert np.all(plus.row_a_share < 0.5)
    assert 0.42 < plus.row_a_share.mean() < 0.48


def test_row_errors_share_the_slots_and_give_the_phase_to_cam_b():
    from corr_cad.mechanics.drive.drive import row_errors

    slots = tuple(1e-4 * np.arange(26))
    a, b = row_errors(ME(slot_angle_errors=slots, cam_phase_error=0.01), ME(cam_radius_error=1e-3))
    assert a.cam_phase_error == 0.0 and b.cam_phase_error == 0.01
    assert b.slot_angle_errors == slots and b.cam_radius_error == 1e-3
    both = row_errors(ME(roller_radius_error=2e-3))
    assert both[0].roller_radius_error == both[1].roller_radius_error == 2e-3


def test_slot_clearance_frees_the_frame_by_c_over_the_largest_radius():
    """A diametral slot clearance c opens each flank by c/2: the frame turns until the roller
    at the largest centre distance s on each side touches its flank, w = c / (2 s) per side
    (s from the crank-slider formula, both rows' rollers; those at psi = 0 or pi, with no
    arm, take no part)."""
    design = GearDesign()
    c = 0.004
    x = np.radians([0.0, 0.07])
    w = DriveWindup(design, x, errors=ME(slot_clearance=c))
    e, L, z1 = design.eccentricity, design.cam_radius + design.roller_radius, 26
    expected = []
    for phi in design.tooth_count * x:
        psi = np.concatenate(
            [phi - 2 * np.pi * np.arange(z1) / z1, phi + np.pi - 2 * np.pi * np.arange(z1) / z1]
        )
        s = e * np.cos(psi) + np.sqrt(L**2 - (e * np.sin(psi)) ** 2)
        sn = np.sin(psi)
        up, down = sn > 1e-12, sn < -1e-12
        expected.append(c / (2 * s[up].max()) + c / (2 * s[down].max()))
    np.testing.assert_allclose(w.backlash(), expected, rtol=1e-9)


def test_slot_fit_puts_an_oversize_roller_into_both_flanks_under_the_drive():
    """Paper convention: an oversize roller is taken up by its slot; the drive's: the flank
    gap is c/2 - dr, an interference |rho_s| dr more in the roller's chain at c = 0."""
    from corr_cad.mechanics.row.solver_geometry import roller_geometry

    design = GearDesign()
    angles = np.radians([10.0])
    dr = 0.002
    paper = roller_geometry(design, angles, ME(roller_radius_error=dr))
    drive = roller_geometry(design, angles, ME(roller_radius_error=dr, slot_clearance=0.0))
    np.testing.assert_allclose(drive.gap - paper.gap, np.abs(paper.rho_s) * dr, rtol=1e-12)
    loose = roller_geometry(design, angles, ME(roller_radius_error=dr, slot_clearance=0.01))
    np.testing.assert_allclose(
        loose.gap - paper.gap, -np.abs(paper.rho_s) * (0.005 - dr), rtol=1e-12
    )


def test_free_rotation_of_a_preloaded_row_on_a_loose_bearing():
    """A row pressed by oversize rollers holds its cam centre v where their forces balance;
    the crank still turns while the eccentric stays within Pd/2 of it: the free output
    rotation is 2 sqrt((Pd/2)^2 - v_y^2) / (e (z + 1)), at most Pd / (e (z + 1)), and
    close to it since the preload centres the cam to within a fraction of Pd/2."""
    design = GearDesign()
    Pd = 0.006
    res = solve_drive(
        design,
        M0,
        np.radians([3.0, 8.0]),
        errors=ME(roller_radius_error=0.001),
        bearing=EccentricBearing(40, 6.0, 12.0, Pd),
    )
    full = Pd / (design.eccentricity * design.roller_count)
    assert np.all((0.99 * full < res.backlash) & (res.backlash <= full * (1 + 1e-12)))
    rigid = solve_drive(design, M0, np.radians([3.0]), errors=ME(roller_radius_error=0.001))
    assert rigid.backlash[0] == 0.0


def test_full_cycle_shortcut_equals_solving_every_angle():
    from corr_cad.mechanics.row.solver import cycle_angles

    b = EccentricBearing(40, 6.0, 12.0, 0.003)
    e = ME(roller_radius_error=-0.001, cam_phase_error=1e-4)
    short = solve_drive(GearDesign(), M0, positions=104, bearing=b, errors=e)
    every = solve_drive(GearDesign(), M0, cycle_angles(104), bearing=b, errors=e)
    assert short.success and every.success
    np.testing.assert_allclose(short.F_j, every.F_j, rtol=1e-9, atol=1e-9 * every.F_j.max())
    for name in ("row_a_share", "bearing_load", "needle_load_max", "backlash", "cam_rotation"):
        np.testing.assert_allclose(getattr(short, name), getattr(every, name), rtol=1e-9)
    np.testing.assert_allclose(short.rows[1].p_gear, every.rows[1].p_gear, rtol=1e-9, atol=1e-6)


def _zero_arm_preload(angles_deg, solver_class=None):
    """A Monte Carlo sample of the allocation (palmgren, needles without clearance, a 2 um
    equidistant clearance): at crank angle 0.8 pi row B's one loaded roller sits at zero arm."""
    from corr_cad.geometry.modification import ModificationGap
    from corr_cad.mechanics.drive.drive import DriveSolver

    design = GearDesign(tooth_count=9, cam_radius=45.0, roller_radius=4.0, eccentricity=1.5)
    psi = np.linspace(-np.pi, np.pi, 1025)
    gap = ModificationGap(psi, np.full(psi.size, 0.002), tooth_count=9)
    # fmt: off
    ra = (-0.0008647740442234757, -0.0007434644175907912, -0.0007478085647202493,
          0.0003067988650118081, 0.0018867599024790188, 0.001098656539694928,
          0.001164535792691221, 0.0010370740021583198, 0.0003879509220950257,
          0.001670769028683651)
    rb = (-0.001216533426928535, 0.0008057142250132898, 0.0007588107974291116,
          0.0009537988017221295, 0.0017115866718350218, 0.0011822390424279963,
          0.0011032607870296385, -0.000903135557959271, -0.0005307933697898922,
          -0.001472178260026384)
    # fmt: on
    ea = ME(0.000198374750692238, 0.0, -0.002, ra, profile_deviation=gap)
    eb = ME(0.0018123903148058468, 0.0, -0.001, rb, profile_deviation=gap)
    bearing = EccentricBearing(30, 4.0, 10.0)
    angles = np.radians(angles_deg)
    return (solver_class or DriveSolver)(
        design, angles, errors=ea, errors_b=eb, bearing=bearing, contact_model="palmgren"
    )


def test_zero_moment_with_a_preloaded_roller_at_zero_arm_settles():
    """At M0 = 0 nothing fixes the crank rotation of :func:`_zero_arm_preload`. The solve
    (which the free rotation of a preloaded drive calls) must settle: crank moment zero,
    cam B's needles carry its roller."""
    import warnings

    solver = _zero_arm_preload([144.0, 324.0])
    bearing = solver.bearings[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow on the way
        res = solver.result(0.0)
        rev, fwd = solver.free_interval()
    assert res.success, res.message
    np.testing.assert_array_equal(rev, fwd)  # preloaded: no free rotation
    fb = res.rows[1].F_j
    assert np.all(fb.max(axis=1) > 100.0)  # row B's roller is loaded
    # Cam B: its needles' resultant (directions 2 pi j / Z) is its rollers' push.
    Z = bearing.needles
    phi = 2.0 * np.pi * np.arange(Z) / Z
    q = res.needle_loads[1]
    resultant = np.hypot(q @ np.cos(phi), q @ np.sin(phi))
    np.testing.assert_allclose(resultant, res.bearing_load[1], rtol=1e-9)


def test_small_moments_past_a_preloaded_roller_at_zero_arm_settle():
    """From M0 = 0 the crank turns through its free play (the zero-arm roller gives no moment)
    until a roller with an arm takes the moment: each small moment settles, and the crank
    turns further for a larger one."""
    solver = _zero_arm_preload([144.0])
    taus = []
    for m in (1e-3, 0.1, 1.0, 10.0):
        res = solver.result(m)
        assert res.success, (m, res.message)
        taus.append(res.cam_rotation[0])
    assert np.all(np.diff(taus) > 0), taus


def test_the_compiled_bearing_newton_settles_where_the_numpy_one_does():
    """The Monte Carlo's compiled Newton (drive_kernel) keeps the numpy solver's crank floor,
    moment scale and separate step caps: at zero and small moments past a zero-arm roller it
    settles on the same state."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver

    for angles, moments in (([144.0, 324.0], (0.0,)), ([144.0], (0.0, 1e-3, 1.0, 10.0))):
        ref = _zero_arm_preload(angles)
        fast = _zero_arm_preload(angles, CompiledDriveSolver)
        for m in moments:
            a, b = ref.result(m), fast.result(m)
            assert a.success and b.success, (m, b.message)
            np.testing.assert_allclose(b.cam_rotation, a.cam_rotation, rtol=1e-6, atol=1e-12)
            np.testing.assert_allclose(b.F_j, a.F_j, rtol=1e-6, atol=1e-6 * a.F_j.max())


def test_the_datasheet_spans_the_row_that_repeats_last():
    """Row B's own rollers need a tooth pitch even when row A's parts are alike: the same
    errors on row B alone or on row A alone give the same span and the same figures
    (the rows are alike but for a half turn of the crank)."""
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet

    d = GearDesign()
    rr = tuple(0.001 * np.sin(np.arange(d.roller_count)))
    bearing = EccentricBearing(40, 6.0, 12.0)
    spec = DatasheetSpec(
        rated_torque=2.86e6, positions_per_mesh=2, transmission_error_positions_per_turn=4
    )
    figs = []
    for ea, eb in ((ME(), ME(0, 0, 0, rr)), (ME(0, 0, 0, rr), ME())):
        drive = {"errors_b": eb, "bearing": bearing, "bearing_b": bearing}
        figs.append(datasheet(d, spec, errors=ea, drive=drive).figures())
    for f in figs:
        assert f["positions"]["span"] == "one tooth pitch (repeats z times)"
    te = [f["transmission_error_arcsec"]["forward_peak_to_peak"] for f in figs]
    assert te[0] > 0.1
    np.testing.assert_allclose(te[0], te[1], rtol=1e-9)


def _row_b_ring_harmonic(solver_class=None, bearing=NEEDLES):
    """Row B's ring with a 2 um third harmonic, row A nominal, both cams on needles without
    clearance. At 2 pi k / 2600 for k = 1200 and 2450 (positions of the datasheet's grid)
    row B's preload is symmetric about the eccentric: it gives no moment at tau = 0, and
    row A's rollers touch there without load."""
    from corr_cad.geometry.deviations import harmonic_deviation
    from corr_cad.mechanics.drive.drive import DriveSolver

    eb = ME(profile_deviation=harmonic_deviation([(3, 0.002, 0.0)]))
    angles = np.concatenate([2 * np.pi * np.array([1200, 2450]) / 2600, np.radians([100.0])])
    return (solver_class or DriveSolver)(GearDesign(), angles, errors_b=eb, bearing=bearing)


def _balance(res, design=None):
    """Each cam's needles' resultant less its rollers' push (2, P, 2), N, and the crank
    moment (P,), N*mm, from the forces and the geometry written out (crank-slider)."""
    design = design or GearDesign()
    e, L = design.eccentricity, design.cam_radius + design.roller_radius
    out, moment = [], 0.0
    for c in (0, 1):
        row = res.rows[c]
        psi = row.psi
        s = e * np.cos(psi) + np.sqrt(L**2 - (e * np.sin(psi)) ** 2)
        n = np.stack([-s * np.sin(psi) / L, (s * np.cos(psi) - e) / L], axis=-1)
        push = np.einsum("pk,pkx->px", row.F_j, n)
        Z = res.needle_loads[c].shape[1]
        a = 2 * np.pi * np.arange(Z) / Z
        out.append(res.needle_loads[c] @ np.stack([np.sin(a), np.cos(a)], axis=1) - push)
        moment = moment + np.sum(row.geometry.arm * row.F_j, axis=1)
    return np.stack(out), moment


@pytest.mark.parametrize("compiled", [False, True])
def test_zero_moment_with_an_idle_row_rests_its_cam_centred(compiled):
    """At zero moment row A carries nothing where row B's preload is symmetric: cam A is
    held by nothing (its rollers touch without load, its needles have no stiffness at no
    load), so it rests centred and carries nothing; row B's bearing carries its
    rollers' resultant, and the moment is zero, to 1e-9 of the drive's forces."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver

    solver = _row_b_ring_harmonic(CompiledDriveSolver if compiled else None)
    res = solver.result(0.0)
    assert res.success, res.message
    unbalanced, moment = _balance(res)
    scale = res.F_j.sum(axis=(0, 2))  # every roller force of the drive, N
    assert np.all(np.linalg.norm(unbalanced, axis=2) <= 1e-9 * scale)
    e = GearDesign().eccentricity
    assert np.all(np.abs(moment) <= 1e-9 * e * scale)
    idle = slice(0, 2)  # the two symmetric positions
    # Nothing, to 1e-12 of the drive's forces: the Newton settles cam A against cam B's
    # scale (found 1e-19), or the idle rule sets it to exactly zero.
    assert np.all(res.F_j[0, idle] <= 1e-12 * scale[idle, None])
    assert np.all(np.abs(res.needle_loads[0][idle]) <= 1e-12 * scale[idle, None])
    assert np.all(np.abs(res.cam_displacement[0, idle]) <= 1e-12)
    assert np.all(res.F_j[1, idle].sum(axis=1) > 1e4)  # row B preloaded
    assert res.F_j[0, 2].sum() > 10.0  # elsewhere row A balances row B's preload moment
    rev, fwd = solver.free_interval()  # the CLI's path: the preloaded drive's free ends
    np.testing.assert_array_equal(rev, fwd)


@pytest.mark.parametrize("compiled", [False, True])
def test_small_moments_about_an_idle_row_are_continuous(compiled):
    """Moments of +-1e-9 to +-1 N*mm about zero: every solve converges with the moment and
    each bearing in equilibrium; the crank turns monotonically; row A's forces grow from
    nothing with the moment's size either way
    and row B's move by no more than 1e3 N per N*mm."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver

    solver = _row_b_ring_harmonic(CompiledDriveSolver if compiled else None)
    moments = np.array([-1.0, -1e-3, -1e-6, -1e-9, 0.0, 1e-9, 1e-6, 1e-3, 1.0])
    results = [solver.result(m) for m in moments]
    assert all(r.success for r in results), [r.message for r in results]
    for m, r in zip(moments, results, strict=True):
        unbalanced, moment = _balance(r)
        scale = r.F_j.sum(axis=(0, 2))
        assert np.all(np.linalg.norm(unbalanced, axis=2) <= 1e-9 * scale)
        assert np.all(np.abs(moment - m) <= 1e-9 * GearDesign().eccentricity * scale)
    tau = np.stack([r.cam_rotation for r in results])
    assert np.all(np.diff(tau, axis=0) >= -1e-18)
    zero = results[4]
    for m, r in zip(moments, results, strict=True):
        change = np.abs(r.F_j - zero.F_j).max(axis=(0, 2))
        assert np.all(change <= 1e3 * abs(m) + 1e-9), (m, change)
    carried = np.stack([r.F_j[0, :2].sum(axis=1) for r in results])  # row A, idle positions
    # Nothing at zero, to 1e-12 of the drive's forces (found 1e-14 N of 3.2e4 N).
    assert np.all(carried[4] <= 1e-12 * zero.F_j.sum(axis=(0, 2))[:2])
    assert np.all(np.diff(carried[4:], axis=0) >= 0) and np.all(np.diff(carried[:5], axis=0) <= 0)
    assert np.all(carried[[0, 8]] > 0.05)


SWEEP_MOMENTS = np.array([1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0])  # N*mm


def _loose_sweep(compiled):
    """:func:`_row_b_ring_harmonic` with a 4 um clearance on both cams, every 10 degrees
    and at the three positions (100, 166 and 339 degrees) where the crank moments of
    :data:`SWEEP_MOMENTS` once left both cams adrift in their clearances."""
    from corr_cad.geometry.deviations import harmonic_deviation
    from corr_cad.mechanics.drive.drive import DriveSolver
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver

    eb = ME(profile_deviation=harmonic_deviation([(3, 0.002, 0.0)]))
    angles = np.radians(np.concatenate([np.arange(0.0, 360.0, 10.0), [100.0, 166.0, 339.0]]))
    cls = CompiledDriveSolver if compiled else DriveSolver
    solver = cls(GearDesign(), angles, errors_b=eb, bearing=EccentricBearing(40, 6.0, 12.0, 0.004))
    return [solver.result(m) for m in SWEEP_MOMENTS]


@pytest.mark.parametrize("compiled", [False, True])
def test_small_moments_on_loose_bearings_reach_equilibrium(compiled):
    """A preloaded row B, both cams in a 4 um clearance, crank moments of 1e-3 to 100
    N*mm: every position converges; each bearing carries its rollers' resultant and the
    rollers' moment is the crank moment, to 1e-9 of the drive's forces; the moment reaches
    the frame through the needles alone, ``e (Q_A,x + Q_B,x) = M`` (the arm of roller k
    is ``e n_k,x``); and the crank turns further the larger the moment."""
    e = GearDesign().eccentricity
    results = _loose_sweep(compiled)
    assert all(r.success for r in results), [r.message for r in results]
    for m, r in zip(SWEEP_MOMENTS, results, strict=True):
        unbalanced, moment = _balance(r)
        scale = r.F_j.sum(axis=(0, 2))
        assert np.all(np.linalg.norm(unbalanced, axis=2) <= 1e-9 * scale)
        assert np.all(np.abs(moment - m) <= 1e-9 * e * scale)
        Z = r.needle_loads[0].shape[1]
        sin = np.sin(2 * np.pi * np.arange(Z) / Z)
        through_needles = e * (r.needle_loads[0] @ sin + r.needle_loads[1] @ sin)
        assert np.all(np.abs(through_needles - m) <= 1e-9 * e * scale)
    tau = np.stack([r.cam_rotation for r in results])
    assert np.all(np.diff(tau, axis=0) > 0)


def test_small_moments_on_loose_bearings_compiled_agrees():
    """The compiled bearing Newton and the numpy one agree to 1e-9 on the loose sweep."""
    for a, b in zip(_loose_sweep(False), _loose_sweep(True), strict=True):
        np.testing.assert_allclose(b.cam_rotation, a.cam_rotation, rtol=1e-9, atol=0)
        np.testing.assert_allclose(b.F_j, a.F_j, rtol=0, atol=1e-9 * a.F_j.max())
        np.testing.assert_allclose(b.cam_displacement, a.cam_displacement, rtol=0, atol=1e-12)


@pytest.mark.parametrize("compiled", [False, True])
def test_an_idle_cam_on_a_loose_bearing_rests_within_its_free_play(compiled):
    """With a 4 um clearance, cam A idles at zero moment at every position of
    :func:`_row_b_ring_harmonic` (it slides in its clearance instead of pressing its
    rollers): it carries nothing (its rollers at most 1e-12 of the drive's forces, its
    needles none) and sits within Pd / 2 of its eccentric's centre; the moment and cam B
    are in equilibrium."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver

    Pd = 0.004
    solver = _row_b_ring_harmonic(
        CompiledDriveSolver if compiled else None, EccentricBearing(40, 6.0, 12.0, Pd)
    )
    res = solver.result(0.0)
    assert res.success, res.message
    scale = res.F_j.sum(axis=(0, 2))
    assert np.all(res.F_j[0].sum(axis=1) <= 1e-12 * scale)
    assert np.all(res.needle_loads[0] == 0.0)
    assert np.all(np.linalg.norm(res.cam_displacement[0], axis=1) <= Pd / 2)
    unbalanced, moment = _balance(res)
    assert np.all(np.linalg.norm(unbalanced, axis=2) <= 1e-9 * scale)
    assert np.all(np.abs(moment) <= 1e-9 * GearDesign().eccentricity * scale)
