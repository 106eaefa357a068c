"""Load-independent losses, the lubricant, a_ISO and the thermal network, against hand values.

Drag: Palmgren's ``M0 = 1e-7 f0 (nu n)^(2/3) dm^3`` evaluated by hand at two
speeds and two viscosities chosen so that ``(nu n)^(2/3)`` is a whole number
or a power of 2 times one. Thermal: a one-node network against its closed
form ``T = T_amb + P / (h A) (1 - exp(-t h A / C))`` to 1e-6.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from corr_cad.errors import SolverError
from corr_cad.mechanics.life_modified import (
    a_iso_roller,
    fatigue_load_limit,
    modified_life,
    reference_viscosity,
    static_rating_roller,
)
from corr_cad.mechanics.losses.bearing_drag import DragBearing, LoadIndependent, palmgren_m0
from corr_cad.mechanics.losses.lubrication import ISO_VG_NU100, Lubricant, walther_viscosity
from corr_cad.mechanics.losses.thermal_network import ThermalNetwork, one_node_closed_form


# --- Drag ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("nu", "n", "expected"),
    [
        # dm = 50 mm, f0 = 2: 1e-7 * 2 * 125000 = 0.025 N*mm per unit of (nu n)^(2/3)
        (20.0, 400.0, 10.0),  # nu n = 8000: 8000^(2/3) = 400
        (20.0, 800.0, 10.0 * 2 ** (2 / 3)),  # 16000 = 2 * 8000
        (80.0, 400.0, 10.0 * 4 ** (2 / 3)),  # 32000 = 4 * 8000
        (80.0, 800.0, 40.0),  # 64000: 64000^(2/3) = 1600
    ],
)
def test_drag_palmgren_by_hand(nu, n, expected):
    assert palmgren_m0(2.0, nu, n, 50.0) == pytest.approx(expected, rel=1e-12)


def test_drag_below_the_knee_is_constant_and_meets_the_upper_branch():
    low = 160e-7 * 2.0 * 50.0**3  # 4 N*mm
    assert palmgren_m0(2.0, 10.0, 100.0, 50.0) == pytest.approx(4.0, rel=1e-12)
    assert palmgren_m0(2.0, 10.0, 0.0, 50.0) == pytest.approx(low, rel=1e-12)
    # the two branches meet at nu n = 2000 within 1 % (2000^(2/3) = 158.7 against 160)
    assert palmgren_m0(2.0, 10.0, 200.0, 50.0) / low == pytest.approx(1.0, abs=0.01)


def test_drag_reflected_to_the_crank():
    """Power of each element = crank moment * crank speed; a bearing at k x the crank
    reflects k M0(k n); seals are constant moments."""
    oil = Lubricant.iso_vg(68)
    li = LoadIndependent(
        oil,
        (DragBearing("b", 2, 50.0, 2.0, 0.5),),
        input_seal=100.0,
        output_seal=260.0,
        input_per_crank=5.0,
        output_per_crank=1 / 26,
    )
    n, t = 1000.0, 40.0
    nu = oil.viscosity(t)
    by_hand = 2 * 0.5 * 1e-7 * 2.0 * (nu * 500.0) ** (2 / 3) * 50.0**3 + 500.0 + 10.0
    assert li.crank_moment(n, t) == pytest.approx(by_hand, rel=1e-12)
    assert li.power_W(n, t) == pytest.approx(by_hand * 1e-3 * n * 2 * math.pi / 60, rel=1e-12)
    # at standstill: Palmgren's constant branch and the seals (the starting torque)
    assert li.crank_moment(0.0, t) == pytest.approx(2 * 0.5 * 160e-7 * 2 * 50.0**3 + 510.0)
    # cold oil drags more
    assert li.crank_moment(n, 0.0) > li.crank_moment(n, 40.0) > li.crank_moment(n, 80.0)


# --- Lubricant -------------------------------------------------------------------------------
def test_walther_through_its_two_points_and_monotone():
    assert walther_viscosity(68.0, 8.53, 40.0) == pytest.approx(68.0, rel=1e-12)
    assert walther_viscosity(68.0, 8.53, 100.0) == pytest.approx(8.53, rel=1e-12)
    t = np.linspace(-20.0, 150.0, 50)
    assert np.all(np.diff(walther_viscosity(68.0, 8.53, t)) < 0.0)


@pytest.mark.parametrize(
    ("grade", "rows"),
    [
        # ASTM D2270 Table 1 rows around nu_100: (Y, L, H)
        (68, ((8.5, 111.5, 65.32), (8.6, 113.9, 66.48))),
        (220, ((18.7, 437.3, 207.6), (18.8, 441.5, 209.3))),
    ],
)
def test_iso_vg_table_is_vi_95_by_astm_d2270(grade, rows):
    y = ISO_VG_NU100[grade]
    (y0, l0, h0), (y1, l1, h1) = rows
    w = (y - y0) / (y1 - y0)
    L, H = l0 + w * (l1 - l0), h0 + w * (h1 - h0)
    vi = 100.0 * (L - grade) / (L - H)
    assert vi == pytest.approx(95.0, abs=0.05)


def test_lubricant_refuses_impossible_oils():
    with pytest.raises(SolverError, match="iso_vg = 69"):
        Lubricant.iso_vg(69)
    with pytest.raises(SolverError, match="below viscosity_40C"):
        Lubricant(8.0, 9.0)


# --- Churning (Changenet & Velex) ------------------------------------------------------------
def _churning_by_hand(n_rpm, nu_mm2s, rp=27.0, b=15.0, h=10.0, v0_l=1.0, rho=870.0):
    """Changenet & Velex (2007) written out in SI: T = 0.5 rho w^2 S_m R^3 C_m, N*mm."""
    w = n_rpm * 2.0 * math.pi / 60.0
    r, bb, hh, nu, v0 = rp / 1e3, b / 1e3, h / 1e3, nu_mm2s / 1e6, v0_l / 1e3
    theta = math.acos(1.0 - h / rp)
    s_m = r**2 * (2.0 * theta - math.sin(2.0 * theta)) + 2.0 * r * bb * theta
    fr, re, re_c = w**2 * r / 9.80665, w * r**2 / nu, w * r * bb / nu
    d = 2.0 * r
    c1 = 1.366 * (hh / d) ** 0.45 * (v0 / d**3) ** 0.1 * fr**-0.6 * re**-0.21
    c2 = 3.644 * (hh / d) ** 0.1 * (v0 / d**3) ** -0.35 * fr**-0.88 * (bb / d) ** 0.85
    return 1e3 * 0.5 * rho * w**2 * s_m * r**3, c1, c2, re_c


def test_churning_by_hand_at_two_speeds_and_viscosities():
    from corr_cad.mechanics.losses.churning import ChurningGear

    g = ChurningGear("wheel", 1, 27.0, 15.0, 10.0, 1.0, 1.0)
    # 500 r/min in ISO VG 68 at 40 C: Re_c = 52.4 x 0.027 x 0.015 / 68e-6 = 312, first law
    base, c1, _, re_c = _churning_by_hand(500.0, 68.0)
    assert re_c < 6000.0
    assert g.moment(500.0, 68.0) == pytest.approx(base * c1, rel=1e-12)
    # 3000 r/min in a thin oil (5 mm^2/s): Re_c = 25,400, second law
    base, _, c2, re_c = _churning_by_hand(3000.0, 5.0)
    assert re_c > 9000.0
    assert g.moment(3000.0, 5.0) == pytest.approx(base * c2, rel=1e-12)
    # the band 6000-9000: linear in Re_c; standstill: no churning
    n_mid = 7500.0 * 20.0e-6 / (0.027 * 0.015) * 60.0 / (2.0 * math.pi)
    base, c1, c2, re_c = _churning_by_hand(n_mid, 20.0)
    assert re_c == pytest.approx(7500.0)
    assert g.moment(n_mid, 20.0) == pytest.approx(base * 0.5 * (c1 + c2), rel=1e-12)
    assert g.moment(0.0, 68.0) == 0.0
    # into the crank's drag: count x speed ratio x the wheel's torque at its own speed
    lub = Lubricant.iso_vg(68)
    li = LoadIndependent(
        lubricant=lub, churning=(ChurningGear("c", 1, 27.0, 15.0, 10.0, 1.0, 4.0),)
    )
    nu = lub.viscosity(40.0)
    assert li.moments(100.0, 40.0)["c"] == pytest.approx(4.0 * g.moment(400.0, nu), rel=1e-12)
    assert li.crank_moment(0.0, 40.0) == 0.0  # nothing at standstill: starting torque unchanged
    with pytest.raises(SolverError, match="immersion_depth_mm = 60"):
        ChurningGear("wheel", 1, 27.0, 15.0, 60.0, 1.0, 1.0)


# --- a_ISO -----------------------------------------------------------------------------------
def test_a_iso_by_hand_and_its_limits():
    # kappa = 1, e_C C_u / P = 0.5: 0.1 [1 - (1.5859 - 1.2348)^0.83 0.5^0.4]^-9.185
    by_hand = 0.1 * (1.0 - 0.3511**0.83 * 0.5**0.4) ** -9.185
    assert a_iso_roller(1.0, 0.5) == pytest.approx(by_hand, rel=1e-12)
    # each piece of the standard at one point of its own (kappa 0.2, 0.6, 2)
    for kappa, x1, x2 in ((0.2, 1.3993, 0.054381), (0.6, 1.2348, 0.19087), (2.0, 1.2348, 0.071739)):
        inner = 1.5859 - x1 / kappa**x2
        by_hand = 0.1 * (1.0 - inner**0.83 * 0.5**0.4) ** -9.185
        assert a_iso_roller(kappa, 0.5) == pytest.approx(by_hand, rel=1e-12), kappa
    assert a_iso_roller(2.0, 0.0) == pytest.approx(0.1)  # no fatigue limit: 0.1
    assert a_iso_roller(4.0, 10.0) == 50.0  # capped
    for k in (0.4, 1.0):  # continuous where the standard's pieces meet
        assert a_iso_roller(k - 1e-9, 0.3) == pytest.approx(a_iso_roller(k, 0.3), rel=1e-3)
    assert a_iso_roller(8.0, 0.3) == a_iso_roller(4.0, 0.3)  # kappa > 4 taken as 4
    ks = np.linspace(0.1, 4.0, 40)
    assert np.all(np.diff([a_iso_roller(k, 0.3) for k in ks]) > 0.0)


def test_reference_viscosity_and_ratings_by_hand():
    assert reference_viscosity(1000.0, 100.0) == pytest.approx(4500.0 / (1000**0.5 * 10.0))
    assert reference_viscosity(500.0, 100.0) == pytest.approx(45000.0 * 500**-0.83 / 10.0)
    c0 = static_rating_roller(1, 40, 12.0, 6.0, 88.4)
    assert c0 == pytest.approx(44.0 * (1 - 6.0 / 88.4) * 40 * 12.0 * 6.0)
    assert fatigue_load_limit(c0, 88.4) == pytest.approx(c0 / 8.2)
    assert fatigue_load_limit(c0, 200.0) == pytest.approx(c0 / 8.2 * 0.5**0.3)


def test_support_bearing_modified_life_by_hand():
    """A tapered pair (Z = 18 per row, D = L = 12 mm, d_m = 87 mm, alpha 15 deg) at the
    crank's 390 r/min in ISO VG 68 at 40 C (68 mm^2/s), P = 40 kN, e_C = 0.5."""
    from corr_cad.mechanics.crank.support_bearing import SupportBearing

    b = SupportBearing("tapered_pair", 18, 12.0, 12.0, 87.0, contact_angle_deg=15.0)
    ca = math.cos(math.radians(15.0))
    c0 = 44.0 * (1.0 - 12.0 * ca / 87.0) * 2 * 18 * 12.0 * 12.0 * ca  # ISO 76, 6.1.1
    assert static_rating_roller(2, 18, 12.0, 12.0, 87.0, b.cos_alpha) == pytest.approx(c0)
    nu1 = 45000.0 * 390.0**-0.83 * 87.0**-0.5  # n < 1000 r/min
    kappa = 68.0 / nu1  # 1.99: the piece 1 <= kappa <= 4
    x = 0.5 * (c0 / 8.2) / 40000.0
    a = 0.1 * (1.0 - (1.5859 - 1.2348 / kappa**0.071739) ** 0.83 * x**0.4) ** -9.185
    l10_h = (b.rating / 40000.0) ** (10.0 / 3.0) * 1e6 / (60.0 * 390.0)
    m = modified_life(l10_h, 68.0, 390.0, 87.0, c0, 40000.0, 0.5)
    assert m["kappa"] == pytest.approx(kappa, rel=1e-12)
    assert 1.0 < a < 50.0 and m["a_ISO"] == pytest.approx(a, rel=1e-12)
    assert m["L10m_h"] == pytest.approx(a * l10_h, rel=1e-12)


# --- Thermal ---------------------------------------------------------------------------------
def test_thermal_one_node_against_closed_form():
    C, hA, P, amb = 50_000.0, 5.0, 300.0, 20.0
    net = ThermalNetwork((C,), (hA,))
    t = np.linspace(0.0, 6 * 3600.0, 37)
    T = net.simulate(t, np.array([0.0]), lambda _t, _T: P, amb)[:, 0]
    assert np.max(np.abs(T - one_node_closed_form(t, P, C, hA, amb))) < 1e-6
    assert net.time_constant_s() == pytest.approx(C / hA)
    assert net.steady(lambda _T: P, amb) == pytest.approx(amb + P / hA, abs=1e-6)
    # one time constant: 1 - 1/e of the rise
    tau = net.simulate(np.array([0.0, C / hA]), np.array([]), lambda _t, _T: P, amb)[-1, 0]
    assert tau - amb == pytest.approx(P / hA * (1 - math.exp(-1.0)), abs=1e-6)


def test_thermal_network_two_nodes_steady_by_hand():
    """Oil node linked to a housing node (G), the housing to the ambient (g): R_00 = 1/G + 1/g."""
    net = ThermalNetwork((1e4, 2e4), (0.0, 4.0), ((0, 1, 10.0),))
    assert net.resistance() == pytest.approx(1 / 10 + 1 / 4)
    assert net.steady(lambda _T: 70.0, 25.0) == pytest.approx(25.0 + 70.0 * 0.35, abs=1e-8)


def test_thermal_refuses_a_network_without_a_way_out():
    with pytest.raises(SolverError):
        ThermalNetwork((1e4,), (0.0,))
