"""Hard cases stay numerically stable, over the whole valid design space.

Designs: tooth count 3-100, cam radius 20-300 mm, eccentricity from 1e-6 mm,
roller radius up to 0.999 of the undercut limit (and of the roller-collision
limit). Loads 1e-9 to 1e9 N*mm. Errors from a clearance that unloads every
roller but one, to interference. No NaN or inf anywhere; the identities
(envelope distance, moment balance by cross products, virtual work) hold;
contacts outside the model's validity are flagged, and only those.
"""

import math

import numpy as np
from hypothesis import assume, given
from hypothesis import strategies as st

from corr_cad import (
    DesignError,
    GearDesign,
    admissible_roller_radius,
    approximate,
    working_profile,
)
from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.solver import solve_forces


@st.composite
def hard_designs(draw):
    z = draw(st.integers(3, 100))
    cam_radius = draw(st.floats(20.0, 300.0))
    e = draw(st.one_of(st.just(1e-6), st.floats(0.01, 0.08 * cam_radius)))
    r_cap = min(
        admissible_roller_radius(z, e, cam_radius),
        0.9 * (cam_radius - e) * math.sin(math.pi / (z + 1)),
        0.3 * cam_radius,
    )
    r = draw(st.floats(0.05, 0.999)) * r_cap
    try:
        return GearDesign(tooth_count=z, cam_radius=cam_radius, roller_radius=r, eccentricity=e)
    except DesignError:
        assume(False)


@given(hard_designs())
def test_profile_and_export_geometry_finite(design):
    w = working_profile(design)
    t = np.linspace(0, 2 * np.pi, 2001)
    q = w.points(t)
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(w.curvature(t)))
    p = kin.locus_points(t, design.tooth_count, design.eccentricity, design.link_length)
    np.testing.assert_allclose(np.linalg.norm(q - p, axis=1), design.roller_radius, rtol=1e-12)
    a = approximate(w, "arcs", 1e-3)
    assert np.all(np.isfinite(a.vertices)) and np.all(np.isfinite(a.bulges))
    assert a.max_deviation <= 1e-3


def _cam_torque(design, res):
    """Torque on the cam about the crank axis from cross products (independent of the arm)."""
    z = design.tooth_count
    phi = res.crank_angles
    theta0 = phi / z
    phi_abs = phi + theta0
    theta = theta0[:, None] + np.arange(design.roller_count)[None, :] * design.slot_pitch_rad
    s = kin.centre_distance(phi_abs[:, None] - theta, design.eccentricity, design.link_length)
    h = s[..., None] * kin.unit_radial(theta)
    o1 = design.eccentricity * kin.unit_radial(phi_abs)[:, None, :]
    c = (h - o1) / np.linalg.norm(h - o1, axis=-1, keepdims=True)
    react = -res.F_j[..., None] * c
    return np.sum(o1[..., 0] * react[..., 1] - o1[..., 1] * react[..., 0], axis=1)


@given(
    hard_designs(),
    st.floats(-9.0, 9.0),
    st.sampled_from(["none", "clearance_all_but_one", "interference"]),
    st.lists(st.floats(0.0, 2 * math.pi), min_size=1, max_size=3),
)
def test_forces_stable_over_loads_and_errors(design, log_load, mode, angles):
    load = 10.0**log_load
    R = design.roller_count
    if mode == "none":
        errors = None
    else:
        gap = 0.5 * design.roller_radius * (1 if mode == "interference" else -1)
        per = [gap] * R
        if mode == "clearance_all_but_one":
            per[0] = 0.0
        errors = ManufacturingErrors(roller_radius_errors=tuple(per))
    res = solve_forces(design, load, np.asarray(angles), errors=errors)
    assert res.success, res.message
    for arr in (res.F_j, res.F_n, res.F_s, res.p_cam, res.p_slot, res.p_gear, res.cam_rotation):
        assert np.all(np.isfinite(arr))
    assert np.all(res.F_j >= 0)
    # Moment balance by cross products, and virtual work with the cam's advance.
    torque = _cam_torque(design, res)
    scale = np.sum(np.abs(res.geometry.arm * res.F_j), axis=1) + 0.55 * load
    assert np.all(np.abs(torque - 0.55 * load) <= 1e-8 * scale)
    work = np.sum(res.F_j * res.geometry.advance, axis=1) * res.cam_rotation
    assert np.all(
        np.abs(work - 0.55 * load * res.cam_rotation) <= 1e-8 * scale * np.abs(res.cam_rotation)
    )
    # Validity flags: exactly where the Hertz half-width reaches a radius.
    k1 = res.geometry.k_roller
    modulus = design.material.contact_modulus
    length = design.roller_length
    b_gear = np.sqrt(4 * res.F_n / (np.pi * length * modulus * (k1 + res.geometry.k_gear)))
    radius_min = np.minimum(1 / k1, 1 / np.maximum(np.abs(res.geometry.k_gear), 1e-300))
    loaded = res.F_j > 0
    clear = np.abs(b_gear / radius_min - 1) > 1e-9
    assert np.array_equal(res.valid_gear[loaded & clear], (b_gear < radius_min)[loaded & clear])
    if mode == "clearance_all_but_one":
        # The one roller without clearance takes load wherever its arm can.
        able = res.geometry.arm[:, 0] > 1e-6 * design.eccentricity
        assert np.all(res.F_j[able, 0] > 0)
