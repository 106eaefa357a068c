"""Palmgren's line contact (``[solver] contact_law = "palmgren"``) against its closed form."""

import math

import numpy as np
import pytest

from corr_cad import GearDesign, solve_forces
from corr_cad.mechanics import palmgren
from corr_cad.mechanics.row.windup import Windup


@pytest.mark.parametrize("Q", [250.0, 2500.0, 12000.0])
def test_approach_is_the_closed_form_at_three_loads(Q):
    # Harris & Kotzalas: delta = 3.84e-5 Q^0.9 / l^0.8 (mm, N, mm), steel.
    length = 12.0
    expected = 3.84e-5 * Q**0.9 / length**0.8
    assert palmgren.approach(Q, length) == pytest.approx(expected, rel=1e-14)
    # The figure: about 6 um at 2.5 kN on a 12 mm roller.
    if Q == 2500.0:
        assert 5.5e-3 < expected < 6.5e-3


def test_other_materials_scale_by_the_compliance_to_the_power_0_9():
    E, nu = 1.1e5, 0.34
    C = 2.0 * (1.0 - nu**2) / E
    C_steel = 2.0 * (1.0 - 0.3**2) / 2.06e5
    Q, length = 1800.0, 10.0
    expected = 3.84e-5 * Q**0.9 / length**0.8 * (C / C_steel) ** 0.9
    assert palmgren.approach(Q, length, C) == pytest.approx(expected, rel=1e-13)
    # Steel's own compliance leaves the law unchanged.
    assert palmgren.STEEL_COMPLIANCE == pytest.approx(C_steel, rel=1e-15)


def test_limits_zero_load_and_the_inverse():
    c = palmgren.coefficient(12.0)
    assert palmgren.approach(0.0, 12.0) == 0.0
    assert palmgren.approach(-5.0, 12.0) == 0.0
    Q, k = palmgren.force_and_slope(np.array([-1e-3, 0.0, 1e-12, 4e-3]), c)
    assert Q[0] == Q[1] == 0.0 and k[0] == k[1] == 0.0
    # The inverse law's slope is finite near zero and vanishes there (Q ~ delta^(10/9)).
    assert 0.0 < k[2] < k[3] < math.inf
    # Inverse and slope against the closed form and a central difference.
    d = 4e-3
    assert Q[3] == pytest.approx((d / c) ** (1 / 0.9), rel=1e-14)
    h = 1e-9
    fd = (palmgren.force(d + h, c) - palmgren.force(d - h, c)) / (2 * h)
    assert k[3] == pytest.approx(fd, rel=1e-6)


def test_roller_compliance_is_three_contacts_in_series():
    design = GearDesign()
    res = solve_forces(design, 1.1e5, np.radians([7.0]), contact_model="palmgren")
    assert res.success
    geo = res.geometry
    F = res.F_j[0]
    on = F > 0
    c = 3.84e-5 / design.roller_length**0.8
    # Each roller: cam + rho_n * gear + |rho_s| * slot approach = the overlap tau a + gap.
    total = (
        c * F**0.9
        + geo.rho_n[0] * c * (geo.rho_n[0] * F) ** 0.9
        + np.abs(geo.rho_s[0]) * c * (np.abs(geo.rho_s[0]) * F) ** 0.9
    )
    overlap = res.cam_rotation[0] * geo.advance[0] + geo.gap[0]
    np.testing.assert_allclose(total[on], overlap[on], rtol=1e-11)
    assert np.all(overlap[~on] <= 0)
    # The moment balance.
    assert np.sum(geo.arm[0] * F) == pytest.approx(0.55 * 1.1e5, rel=1e-12)


def test_palmgren_is_softer_than_the_paper_law():
    """About 5x the approach of the paper's law at 2.5 kN on a roller (the issue's figure)."""
    x = np.radians([0.0])
    paper = Windup(GearDesign(), x).theta(2.86e6)
    palm = Windup(GearDesign(), x, contact_model="palmgren").theta(2.86e6)
    assert 3.0 < float(palm[0] / paper[0]) < 7.0


def test_nominal_drive_rigidity_against_finite_differences():
    """Tangent rigidity from the solved forces (dF/dh = F / (0.9 h)) against a central
    difference of the drive's windup."""
    from corr_cad.mechanics.drive.drive_windup import DriveWindup

    design = GearDesign()
    z1 = design.roller_count
    x = np.radians([0.0, 0.3])
    w = DriveWindup(design, x, contact_model="palmgren")
    T = 2.0e6
    dT = 1e-4 * T
    fd = 2 * dT / (w.theta(T + dT) - w.theta(T - dT))  # N*mm/rad
    res = w.forces(T)
    tangent = []
    for p in range(len(x)):
        stiff = 0.0
        for row in res.rows:
            g = row.geometry
            F = row.F_j[p]
            on = F > 0
            h = row.cam_rotation[p] * g.advance[p] + g.gap[p]
            # M = sum a F(tau a + g): dM/dtau = sum a^2 dF/dh; T = -(z+1) M, theta = -tau/(z+1).
            stiff += np.sum(g.arm[p][on] * g.advance[p][on] * F[on] / (0.9 * h[on]))
        tangent.append(z1**2 * stiff)
    np.testing.assert_allclose(fd, tangent, rtol=1e-6)
    # Catalogue units: a few thousand N*m/arcmin (two rows, Palmgren, rigid cams).
    per_arcmin = np.asarray(tangent) / 1000.0 / (10800.0 / math.pi)
    assert np.all((4000 < per_arcmin) & (per_arcmin < 9000))


def test_scene_contact_law_reaches_the_solver(tmp_path):
    from corr_cad.run.scene.scene import parse_scene

    scene = parse_scene({"solver": {"contact_law": "palmgren"}, "load": {"input_torque": 1e5}})
    assert scene.solver.contact_model == "palmgren"
    assert scene.source["solver"]["contact_law"] == "palmgren"
    plain = parse_scene({"load": {"input_torque": 1e5}})
    assert plain.solver.contact_model == "nonlinear"
    assert "contact_law" not in plain.source["solver"]  # a scene without it keeps its bytes
