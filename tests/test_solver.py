"""Mesh-force solver: identities, an independent solver, symmetry, hard cases, errata."""

import dataclasses

import numpy as np
import pytest

from corr_cad import SolverError, admissible_roller_radius
from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
from corr_cad.mechanics.reference import reference_position
from corr_cad.mechanics.row.solver import VARIANTS, solve_forces

M0 = 1.1e5  # N*mm


@pytest.fixture(scope="module")
def cycle(prototype):
    return solve_forces(prototype, M0, positions=3600)


def _vectors(design, res):
    """Unit directions c, n, u_t of every roller, (P, R, 2), from plain vectors."""
    z = design.tooth_count
    phi = res.crank_angles[:, None]
    theta0 = phi / z
    phi_abs = phi + theta0
    theta = theta0 + np.arange(design.roller_count)[None, :] * design.slot_pitch_rad
    s = kin.centre_distance(phi_abs - theta, design.eccentricity, design.link_length)
    h = s[..., None] * kin.unit_radial(theta)
    o1 = design.eccentricity * kin.unit_radial(phi_abs[:, 0])[:, None, :]
    c = (h - o1) / np.linalg.norm(h - o1, axis=-1, keepdims=True)
    tang = kin.locus_derivative(theta, z, design.eccentricity, design.link_length)
    n = np.stack([tang[..., 1], -tang[..., 0]], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    n *= np.sign(np.sum(n * kin.unit_radial(theta), -1))[..., None]
    return h, o1, c, n, kin.unit_tangential(theta), phi_abs


def test_converges_and_reports(cycle):
    assert cycle.success and cycle.message == "converged"
    assert cycle.moment_residual < 1e-12
    assert cycle.positions_solved == 1800  # 3600 positions, period 2 pi / 26
    assert np.all(np.isfinite(cycle.F_j)) and np.all(cycle.F_j >= 0)


def test_vector_equilibrium_of_every_roller(prototype, cycle):
    res = cycle
    _, _, c, n, ut, _ = _vectors(prototype, res)
    # F_s is reported positive when the roller drives the frame (slot pushes back, -u_t).
    total = res.F_j[..., None] * c - res.F_n[..., None] * n - res.F_s[..., None] * ut
    assert np.abs(total).max() < 1e-9 * res.F_j.max()


def test_sine_rule_with_consistent_signs(prototype, cycle):
    # Lami's theorem: each force over the sine of the angle between the other two.
    res = cycle
    _, _, c, n, ut, _ = _vectors(prototype, res)
    f1, f2, f3 = c, -n, -ut  # directions of F_j, F_n, F_s on the roller

    def sin_between(a, b):
        return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]

    loaded = res.F_j > 0
    k = res.F_j / sin_between(f2, f3)
    # F = k sin(...) with one k per roller; compare forces, not ratios of tiny ones.
    np.testing.assert_allclose(
        res.F_n[loaded], (k * sin_between(f3, f1))[loaded], rtol=1e-9, atol=1e-9 * res.F_n.max()
    )
    np.testing.assert_allclose(
        res.F_s[loaded], (k * sin_between(f1, f2))[loaded], rtol=1e-9, atol=1e-9 * res.F_n.max()
    )


def test_moment_balance_and_virtual_work(prototype, cycle):
    res = cycle
    _, o1, c, _, _, phi_abs = _vectors(prototype, res)
    # Moment of the rollers' reactions on the cam about the crank axis (cross
    # products; angles grow clockwise, hence the sign).
    reaction = -res.F_j[..., None] * c
    torque = np.sum(o1[..., 0] * reaction[..., 1] - o1[..., 1] * reaction[..., 0], axis=1)
    np.testing.assert_allclose(torque, 0.55 * M0, rtol=1e-10)
    # Virtual work: a small cam rotation tau advances the cam surface by
    # (dO1/dphi . c) tau at every roller; the work equals moment x rotation.
    velocity = prototype.eccentricity * kin.unit_tangential(phi_abs[:, 0])[:, None, :]
    advance = np.sum(velocity * c, axis=-1)
    work = np.sum(res.F_j * advance * res.cam_rotation[:, None], axis=1)
    np.testing.assert_allclose(work, 0.55 * M0 * res.cam_rotation, rtol=1e-10)


def test_output_torque_is_ratio_times_cam_moment(prototype, cycle):
    np.testing.assert_allclose(cycle.output_torque, 26 * 0.55 * M0, rtol=1e-10)


def test_linear_contact_limit_closed_form(prototype):
    from corr_cad.mechanics.contact import linear_compliance

    angles = np.radians([0.0, 3.3, 11.0])
    res = solve_forces(prototype, M0, angles, contact_model="linear")
    g = res.geometry
    lam = linear_compliance(prototype.roller_length, prototype.material.contact_modulus)
    k = lam * (1 + g.rho_n**2 + g.rho_s**2)
    a = np.where(g.arm > 0, g.arm, 0.0)
    tau = 0.55 * M0 / np.sum(a * a / k, axis=1)
    np.testing.assert_allclose(res.cam_rotation, tau, rtol=1e-12)
    np.testing.assert_allclose(res.F_j, tau[:, None] * a / k, rtol=1e-11, atol=1e-9)


ERRORS = [
    ManufacturingErrors(),
    ManufacturingErrors(eccentricity_error=0.02),
    ManufacturingErrors(cam_radius_error=0.01),
    ManufacturingErrors(roller_radius_error=-0.01),
    ManufacturingErrors(roller_radius_errors=tuple(np.linspace(-0.008, 0.008, 26))),
    ManufacturingErrors(slot_angle_errors=tuple(np.radians(np.linspace(-0.01, 0.01, 26)))),
    ManufacturingErrors(cam_phase_error=np.radians(0.05), eccentricity_error=0.005),
    ManufacturingErrors(profile_deviation=harmonic_deviation([(3, 0.004, 20.0), (25, 0.002, 0.0)])),
]


@pytest.mark.parametrize("errors", ERRORS)
def test_independent_scalar_solver_agrees(prototype, errors):
    angles = np.radians([0.0, 7.3, 123.4])
    res = solve_forces(prototype, M0, angles, errors=errors)
    for k, a in enumerate(angles):
        F, tau = reference_position(prototype, M0, a, errors=errors)
        np.testing.assert_allclose(res.F_j[k], F, rtol=1e-9, atol=1e-9 * F.max())
        assert res.cam_rotation[k] == pytest.approx(tau, rel=1e-9)


def test_periodicity_and_dedup(prototype):
    full = solve_forces(prototype, M0, positions=520)  # 20 positions per pitch
    step = 520 // 26
    np.testing.assert_allclose(full.F_j[step:, 1:], full.F_j[:-step, :-1], rtol=1e-12, atol=1e-9)
    assert full.positions_solved == 20
    direct = solve_forces(prototype, M0, full.crank_angles[:40])
    np.testing.assert_allclose(direct.F_j, full.F_j[:40], rtol=1e-10, atol=1e-8)


def test_mirror_symmetry(prototype):
    # Reversing the torque mirrors the load: roller at psi under +M carries what
    # the roller at -psi carries under -M.
    angles = np.radians([0.0, 5.0, 40.0])
    fwd = solve_forces(prototype, M0, angles)
    rev = solve_forces(prototype, -M0, -angles)
    R = prototype.roller_count
    mirror = (-np.arange(R)) % R
    np.testing.assert_allclose(rev.F_j[:, mirror], fwd.F_j, rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(rev.F_s[:, mirror], -fwd.F_s, rtol=1e-10, atol=1e-8)


def test_scaling_with_load(prototype):
    angles = np.radians([2.0, 9.0])
    lin1 = solve_forces(prototype, M0, angles, contact_model="linear")
    lin3 = solve_forces(prototype, 3 * M0, angles, contact_model="linear")
    np.testing.assert_allclose(lin3.F_j, 3 * lin1.F_j, rtol=1e-12)
    # The overlap law stiffens (convex): as the load falls it tends to the linear
    # law, and the load spreads slightly less evenly than linear at high load.
    small = solve_forces(prototype, 1e-3, angles)
    lin_small = solve_forces(prototype, 1e-3, angles, contact_model="linear")
    np.testing.assert_allclose(small.F_j, lin_small.F_j, rtol=1e-7, atol=1e-15)
    big = solve_forces(prototype, 1e3 * M0, angles)
    big_lin = solve_forces(prototype, 1e3 * M0, angles, contact_model="linear")
    assert np.max(np.abs(big.F_j - big_lin.F_j) / big_lin.F_j.max()) > 1e-4
    # Contact pressure grows as sqrt(F) (Hertz line contact).
    p1 = solve_forces(prototype, M0, angles, contact_model="linear").p_cam
    p4 = solve_forces(prototype, 4 * M0, angles, contact_model="linear").p_cam
    np.testing.assert_allclose(p4, 2 * p1, rtol=1e-12)


def test_zero_and_tiny_load(prototype):
    zero = solve_forces(prototype, 0.0, positions=52)
    assert zero.success and np.all(zero.F_j == 0) and np.all(zero.p_gear == 0)
    tiny = solve_forces(prototype, 1e-9, positions=52)
    assert tiny.success and np.all(np.isfinite(tiny.F_j))
    ref = solve_forces(prototype, M0, positions=52)
    np.testing.assert_allclose(tiny.F_j * (M0 / 1e-9), ref.F_j, rtol=2e-3, atol=1e-6)


def test_all_rollers_start_in_clearance(prototype):
    err = ManufacturingErrors(roller_radius_error=-0.05)
    res = solve_forces(prototype, M0, positions=104, errors=err)
    assert res.success
    assert res.loaded_count.min() >= 1
    assert res.loaded_count.max() < 13  # far fewer than nominal
    np.testing.assert_allclose(np.sum(res.geometry.arm * res.F_j, axis=1), 0.55 * M0, rtol=1e-10)


def test_just_below_undercut(prototype):
    r_adm = admissible_roller_radius(25, 3.5, 135.0)
    d = dataclasses.replace(prototype, roller_radius=0.999 * r_adm)
    res = solve_forces(d, M0, positions=260)
    assert res.success and np.all(np.isfinite(res.p_gear))


def test_errata_variants_differ_where_they_should(prototype):
    angles = np.radians([3.0, 10.0])
    base = solve_forces(prototype, M0, angles)
    for v in ("eq3_printed", "eq16_sin_gamma", "rj_for_link_length"):
        alt = solve_forces(prototype, M0, angles, variants=(v,))
        assert alt.success
        # L = Rj instead of Rj + r tilts the cam force by ~0.1 %: small, but there.
        assert np.max(np.abs(alt.F_n - base.F_n)) > 5e-4 * base.F_n.max(), v
    # Loading only the working half changes nothing without errors (the return
    # half is never loaded), but does when errors preload the return side.
    half = solve_forces(prototype, M0, angles, variants=("working_half_only",))
    np.testing.assert_allclose(half.F_j, base.F_j, rtol=1e-12, atol=1e-9)
    err = ManufacturingErrors(cam_radius_error=0.01)
    e_base = solve_forces(prototype, M0, angles, errors=err)
    e_half = solve_forces(prototype, M0, angles, errors=err, variants=("working_half_only",))
    assert e_base.loaded_count.max() == 26 and e_half.loaded_count.max() <= 13


def test_eq16_variant_breaks_virtual_work(prototype):
    res = solve_forces(prototype, M0, np.radians([5.0]), variants=("eq16_sin_gamma",))
    g = res.geometry
    # Moment balance still holds with the correct arm ...
    assert np.sum(g.arm * res.F_j) == pytest.approx(0.55 * M0, rel=1e-10)
    # ... but the compatibility advance is not the arm, so work != moment x rotation.
    work = np.sum(res.F_j * g.advance * res.cam_rotation[:, None])
    assert abs(work - 0.55 * M0 * res.cam_rotation[0]) > 1e-3 * abs(work)


def test_bad_inputs(prototype):
    with pytest.raises(SolverError, match="contact_model"):
        solve_forces(prototype, M0, contact_model="hertz3d")
    with pytest.raises(SolverError, match="load_share"):
        solve_forces(prototype, M0, load_share=1.5)
    with pytest.raises(SolverError, match="input_torque"):
        solve_forces(prototype, float("nan"))
    with pytest.raises(SolverError, match="variant"):
        solve_forces(prototype, M0, variants=("nope",))
    with pytest.raises(SolverError, match="positions"):
        solve_forces(prototype, M0, positions=0)
    assert set(VARIANTS) == {
        "eq3_printed",
        "eq16_sin_gamma",
        "rj_for_link_length",
        "working_half_only",
    }


def test_backlash_is_the_zero_torque_band(prototype):
    # Tiny forward and reverse torques leave the cam at the two ends of the
    # band in which no roller is loaded; the output turns 1/(z+1) of it.
    err = ManufacturingErrors(roller_radius_error=-0.01)
    angles = np.radians([0.0, 4.0, 9.0])
    fwd = solve_forces(prototype, 1e-9, angles, errors=err)
    rev = solve_forces(prototype, -1e-9, angles, errors=err)
    band = (fwd.cam_rotation - rev.cam_rotation) / 26
    np.testing.assert_allclose(fwd.backlash, band, rtol=1e-6)
    assert np.all(fwd.backlash > 0)
    tight = solve_forces(prototype, M0, angles, errors=ManufacturingErrors(cam_radius_error=0.01))
    assert np.all(tight.backlash == 0)
    with pytest.warns(DeprecationWarning, match="ForceResult.backlash"):
        np.testing.assert_array_equal(fwd.lost_motion, fwd.backlash)  # the deprecated alias


def test_loaded_count_does_not_depend_on_the_resolution(prototype):
    """A roller at the edge of the loaded zone (F ~ 1e-13 N) is not counted as loaded.

    The 72 positions are among the 720, so the fewest loaded rollers over the
    720 can never be more than over the 72; with round-off counted as load it
    once was (13 against 12).
    """
    coarse = solve_forces(prototype, 1.1e5, positions=72)
    fine = solve_forces(prototype, 1.1e5, positions=720)
    assert fine.loaded_count.min() <= coarse.loaded_count.min()
    assert np.array_equal(fine.loaded_count[::10], coarse.loaded_count)
    F = fine.F_j
    assert not np.any(fine.loaded & (F < 1e-6 * F.max(axis=1, keepdims=True)))


NOMINAL_CASES = [
    dict(positions=3600),
    dict(positions=3640),
    dict(positions=360, input_torque=-M0),
    dict(crank_angles=np.radians([0.0, 7.3, 90.0, 123.4, 180.0, 400.0, -30.0])),  # and psi = 0, pi
    dict(positions=360, contact_model="linear"),
    dict(positions=360, variants=("working_half_only",)),
    dict(positions=360, psi_contact_limit=2.5),
    dict(positions=52, input_torque=1e9),  # heavy: more Newton steps
]


@pytest.mark.parametrize("case", NOMINAL_CASES, ids=lambda c: ",".join(map(str, c)))
def test_nominal_fast_path_equals_general_path(prototype, monkeypatch, case):
    """The closed-form path without errors (solver_nominal) against the general one.

    Same model, other arithmetic: closed-form geometry, a window of rollers,
    the linear start without sorting. Agreement to round-off, every field.
    """
    from corr_cad.mechanics.row import solver

    case = dict(case)
    torque = case.pop("input_torque", M0)
    taken = []
    fast_result = solver._nominal_result
    monkeypatch.setattr(solver, "_nominal_result", lambda *a: taken.append(1) or fast_result(*a))
    fast = solve_forces(prototype, torque, **case)
    assert taken, "the fast path was not taken"
    monkeypatch.setattr(solver, "_nominal_result", lambda *a: None)
    slow = solve_forces(prototype, torque, **case)
    assert fast.success and slow.success
    for name in ("F_j", "F_n", "F_s", "p_cam", "p_slot", "p_gear", "cam_rotation"):
        x, y = getattr(fast, name), getattr(slow, name)
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12 * np.abs(y).max(), err_msg=name)
    for name in ("valid_cam", "valid_slot", "valid_gear", "loaded", "psi", "crank_angles"):
        assert np.array_equal(getattr(fast, name), getattr(slow, name)), name
    for name in ("s", "rho_n", "rho_s", "advance", "arm", "gap", "k_roller", "k_gear"):
        x, y = getattr(fast.geometry, name), getattr(slow.geometry, name)
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-13 * np.abs(y).max(), err_msg=name)
    assert np.array_equal(fast.geometry.loadable, slow.geometry.loadable)
    assert fast.geometry.k_cam == slow.geometry.k_cam


def test_blocks_change_no_bit(prototype, monkeypatch):
    """Blocks are written into outputs allocated once: the same bits as one block."""
    from corr_cad.mechanics.row import solver

    err = ManufacturingErrors(eccentricity_error=0.02)
    blocks = solve_forces(prototype, M0, positions=720, errors=err)
    monkeypatch.setattr(solver, "_BLOCK_ELEMENTS", 10**9)
    one = solve_forces(prototype, M0, positions=720, errors=err)
    for k, v in one.__dict__.items():
        if isinstance(v, np.ndarray):
            assert np.array_equal(getattr(blocks, k), v), k
    for k in one.geometry.expanded().__dict__:
        assert np.array_equal(getattr(blocks.geometry, k), getattr(one.geometry, k)), k
    assert (blocks.success, blocks.iterations) == (one.success, one.iterations)
