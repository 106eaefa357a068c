"""The measured ring's datasheet: a tooth turned by 36 arcsec in the transmission error.

The ring is built here from the closed form (roller centre
``s = e cos psi + sqrt(L^2 - e^2 sin^2 psi)``, ``psi = z t``, ``L = Rj + r``,
working profile = the locus offset outwards by ``r``), tooth space ``K``
turned by ``DELTA`` about the ring centre, written as a measured CSV and run
through the CLI. Nothing of corr_cad's profile or solver code is imported.

Expected, from kinematics alone (crank locked, ring fixed): a whole ring
turned by ``d`` turns the output by ``d z / (z + 1)`` (the crank, relative to
the ring, turns by ``-d``; the output follows at ``1 / (z + 1)`` of it). A
roller on the turned tooth sees the gap it would see in a ring turned as a
whole, so where it binds first the output stands ``DELTA z / (z + 1)`` =
34.62 arcsec away from where its unturned twin would hold it. It binds while
it is driven against the turned flank that moved into the tooth space: the
flank at ``psi < 0`` (material added for ``DELTA > 0``), which the forward
drive loads (the cam pushes rollers outwards where ``ds/d(crank) > 0``,
i.e. ``psi < 0``). With ``psi = crank - t`` the eccentric then points within
the half turn behind the tooth: ``(z + 1) x`` in ``(t_K - pi, t_K)``, once per
input turn (``z + 1`` windows of 6.9 deg of output, 13.85 deg apart).

Two rings:

* ``relieved``: the ring as shops make it, every flank relieved by 20 um
  (equidistant modification), so the drive has backlash and the turned
  tooth acts kinematically: the full ``DELTA z / (z + 1)`` shows.
* ``conjugate``: the exact conjugate ring, zero backlash: the turned tooth is
  squeezed against the other rollers (a preload) and the feature is the
  stiffness share of that interference, a fraction of the kinematic one.
"""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

Z, E, RJ, R = 25, 3.5, 135.0, 8.0
L = RJ + R
R1 = Z + 1
PITCH = 2 * math.pi / Z
AS = math.radians(1 / 3600)  # one arcsec in rad
K, DELTA_AS = 5, 36.0  # tooth space 5 turned by +36 arcsec
RELIEF = 0.020  # mm, every flank of the relieved ring
M = 120  # points per tooth
KINEMATIC_AS = DELTA_AS * Z / R1  # 34.615 arcsec


def locus(t):
    """Roller-centre locus, its unit outward normal and ds/dpsi at polar angles t."""
    psi = Z * t
    w = np.sqrt(L * L - (E * np.sin(psi)) ** 2)
    s = E * np.cos(psi) + w
    dsdpsi = -E * np.sin(psi) * s / w
    ur = np.stack([np.sin(t), np.cos(t)], -1)
    ut = np.stack([np.cos(t), -np.sin(t)], -1)
    n = s[..., None] * ur - (Z * dsdpsi)[..., None] * ut
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return s[..., None] * ur, n, dsdpsi


def turn(p, a):
    """Turn points so that their polar angle (from +y towards +x) grows by ``a``."""
    c, s = math.cos(a), math.sin(a)
    return np.stack([p[:, 0] * c + p[:, 1] * s, -p[:, 0] * s + p[:, 1] * c], 1)


def ring_points(relief):
    out = []
    for k in range(Z):
        t = ((np.arange(M) + 0.5) / M - 0.5) * PITCH + k * PITCH
        h, n, _ = locus(t)
        p = h + (R + relief) * n  # relief: material removed, the flank moves outwards
        if k + 1 == K:
            p = turn(p, DELTA_AS * AS)
        out.append(p)
    return np.vstack(out)


def run(folder, relief, extra=""):
    folder.mkdir(parents=True, exist_ok=True)
    pts = ring_points(relief)
    (folder / "ring.csv").write_text(
        "x,y\n" + "\n".join(f"{x:.10f},{y:.10f}" for x, y in pts) + "\n"
    )
    (folder / "s.toml").write_text(
        '[export]\nformats = ["datasheet", "inspection"]\n'
        '[errors]\nmeasured_profile = "ring.csv"\n' + extra + "[load]\ninput_torque = 1.1e5\n"
        "[datasheet]\npositions_per_mesh = 1\n"
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out"],
        cwd=folder,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    out = folder / "out"
    te = np.loadtxt(out / "transmission_error.csv", delimiter=",", skiprows=1)
    return (
        r,
        te,
        json.loads((out / "datasheet.json").read_text()),
        json.loads((out / "inspection.json").read_text()),
    )


@pytest.fixture(scope="module")
def relieved(tmp_path_factory):
    # Oversized rollers in [errors]: the measured ring's datasheet has nominal other parts.
    return run(tmp_path_factory.mktemp("relieved"), RELIEF, "roller_radius_error = 0.004\n")


@pytest.fixture(scope="module")
def conjugate(tmp_path_factory):
    return run(tmp_path_factory.mktemp("conjugate"), 0.0)


def forward_window(x_deg):
    """Output angles where the eccentric points within the half turn behind tooth K."""
    tk = (K - 1) * PITCH
    a = np.mod(R1 * np.radians(x_deg) - (tk - math.pi), 2 * math.pi)
    return (a > 0) & (a < math.pi), np.floor(
        (R1 * np.radians(x_deg) - tk + math.pi) / (2 * math.pi)
    )


def free_ends_closed_form(x, registration, relief):
    """Ends of the free rotation, rad, from the registered ring's geometry alone.

    Crank locked, output turned by ``w``: roller i (polar angle ``t``,
    ``psi = z t``) keeps riding on the cam, its centre at ``s(psi - w)``, while
    the ring's locus under it is at ``s(psi + z w)``: the normal overlap grows
    by ``-(z + 1) s'(psi) cos(beta) w``. The ring's normal deviation at the
    roller (material added +) closes it at ``w = dev / ((z + 1) s' cos beta)``.
    The registered ring is the measured one moved by ``-centre`` and turned by
    ``-rotation`` (datasheet.json ``ring.registration``).
    """
    t = x[:, None] + 2 * math.pi * np.arange(R1) / R1
    h, n, dsdpsi = locus(t)
    cosb = np.sum(n * np.stack([np.sin(t), np.cos(t)], -1), -1)
    slope = R1 * dsdpsi * cosb
    on = np.abs(np.mod(t - (K - 1) * PITCH + math.pi, 2 * math.pi) - math.pi) < PITCH / 2
    ang = np.where(on, DELTA_AS * AS, 0.0) - math.radians(registration["rotation_deg"])
    d = ang[..., None] * np.stack([h[..., 1], -h[..., 0]], -1) - np.array(registration["centre_mm"])
    dev = -np.sum(d * n, -1) - relief
    with np.errstate(divide="ignore"):
        lo = np.max(np.where(slope > 0, dev / slope, -np.inf), axis=1)
        hi = np.min(np.where(slope < 0, dev / slope, np.inf), axis=1)
    return lo, hi


@pytest.mark.slow
def test_datasheet_says_which_ring(relieved):
    r, _, sheet, insp = relieved
    ring = sheet["ring"]
    assert ring["profile"] == "measured" and ring["other_parts"] == "nominal"
    assert ring["file"] == "ring.csv" and len(ring["sha256"]) == 64
    assert ring["errors_not_applied"] == ["roller_radius_error"]
    assert "of the measured ring ring.csv" in r.stdout
    b = sheet["backlash_arcmin"]["max"]
    assert f"measured ring, other parts nominal: backlash {b:.4g} arcmin, lost motion" in r.stdout
    assert insp["predicted"]["ring"]["sha256"] == ring["sha256"]


@pytest.mark.slow
def test_backlash_is_the_registered_rings_kinematics(relieved):
    """Free ends from the measured ring alone, the oversized rollers not applied: to 1e-4."""
    _, _, sheet, insp = relieved
    p = sheet["positions"]
    x = np.radians(np.linspace(p["output_angle_from_deg"], p["output_angle_to_deg"], p["count"]))
    lo, hi = free_ends_closed_form(x, sheet["ring"]["registration"], RELIEF)
    b = (hi - lo) * 10800 / math.pi  # arcmin
    got = sheet["backlash_arcmin"]
    for k, v in (("min", b.min()), ("mean", b.mean()), ("max", b.max())):
        assert got[k] == pytest.approx(v, rel=1e-4), k
    # 1.776 arcmin from the relief; the turned tooth narrows it by about 34.6 arcsec
    assert got["max"] == pytest.approx(1.776, abs=0.01)
    assert got["max"] - got["min"] == pytest.approx(KINEMATIC_AS / 60, abs=0.05)
    pred = insp["predicted"]["measured"]
    assert pred["backlash_arcmin"]["max"] == got["max"]
    assert insp["predicted"]["nominal"]["backlash_arcmin"]["max"] == 0.0


@pytest.mark.slow
def test_turned_tooth_shows_at_its_angle_with_the_kinematic_amplitude(relieved):
    _, te, sheet, insp = relieved
    x, fwd, rev = te[:, 0], te[:, 1], te[:, 2]
    assert len(x) == 360 * R1 and x[-1] < 360.0
    win, turn_no = forward_window(x)
    base = np.median(fwd[~win])
    # The feature: forward, in every one of the z + 1 windows, DELTA z / (z + 1) high.
    assert np.ptp(fwd) == pytest.approx(KINEMATIC_AS, rel=0.03)  # measured 34.71
    assert fwd.max() - base == pytest.approx(KINEMATIC_AS, abs=2.0)  # measured 33.25
    peaks = [fwd[win & (turn_no == j)].max() - base for j in np.unique(turn_no[win])]
    assert len(peaks) >= R1 and min(peaks) > 0.7 * KINEMATIC_AS  # measured 25.1 (edge windows)
    # Flat elsewhere: within 1.5 arcsec of the baseline (measured 1.24; registration's
    # centre shift of 0.33 um and the mesh ripple); reverse never meets the turned flank.
    assert np.abs(fwd[~win] - base).max() < 1.5
    assert np.ptp(rev) < 2.5  # measured 1.97
    # the inspection report gives the same figures
    p = insp["predicted"]["measured"]["transmission_error_arcsec"]
    assert p["forward_peak_to_peak"] == pytest.approx(np.ptp(fwd), rel=1e-9)
    assert p["reverse_peak_to_peak"] == sheet["transmission_error_arcsec"]["reverse_peak_to_peak"]


@pytest.mark.slow
def test_conjugate_ring_preloads_the_turned_tooth(conjugate):
    """Zero backlash: the feature sits in the same windows, a stiffness share of 34.6 arcsec."""
    _, te, sheet, insp = conjugate
    x, fwd = te[:, 0], te[:, 1]
    win, _ = forward_window(x)
    base = np.median(fwd[~win])
    amp = fwd.max() - base
    assert win[np.argmax(fwd)]
    assert 0.05 * KINEMATIC_AS < amp < 0.5 * KINEMATIC_AS  # measured 3.93
    assert fwd[~win].max() - base < 0.25 * amp
    assert sheet["backlash_arcmin"]["max"] == 0.0
    assert insp["predicted"]["measured"]["lost_motion_arcmin"]["max"] > 0


def test_play_figures_equal_the_datasheets_on_the_same_positions():
    """The inspection's five-solve figures are the datasheet's (650 positions each)."""
    from corr_cad.geometry.design import GearDesign
    from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet, play_figures

    err = ManufacturingErrors(
        profile_deviation=harmonic_deviation([(0, -0.01, 0.0), (3, -0.004, 20.0)])
    )
    spec = DatasheetSpec(
        rated_torque=2.86e6, positions_per_mesh=1, transmission_error_positions_per_turn=Z
    )
    d = datasheet(GearDesign(), spec, errors=err).figures()
    p = play_figures(GearDesign(), spec, errors=err)
    assert p["positions"] == d["positions"]["count"] == Z * R1
    for k in ("backlash_arcmin", "lost_motion_arcmin"):
        for s in ("min", "mean", "max"):
            assert p[k][s] == pytest.approx(d[k][s], rel=1e-9, abs=1e-12), (k, s)
    assert d["backlash_arcmin"]["max"] > 0.1  # the harmonic opens a clearance
    for s in ("forward_peak_to_peak", "reverse_peak_to_peak"):
        got, want = p["transmission_error_arcsec"][s], d["transmission_error_arcsec"][s]
        assert got == pytest.approx(want, rel=1e-9) and want > 1.0


def test_other_errors_have_no_effect_on_a_measured_rings_datasheet():
    from corr_cad.run.scene.scene_text import no_effect_warnings

    data = {
        "errors": {"measured_profile": "ring.csv", "roller_radius_error": 0.004},
        "export": {"formats": ["datasheet"]},
        "datasheet": {"rated_torque_Nm": 2860.0},
    }
    warned = no_effect_warnings(data, ("datasheet",), False)
    assert any(w.startswith("[errors] roller_radius_error has no effect") for w in warned)
    data["errors"].pop("measured_profile")
    assert not any(
        "roller_radius_error" in w for w in no_effect_warnings(data, ("datasheet",), False)
    )


def test_datasheet_section_has_an_effect_on_the_inspection():
    """The inspection's predicted play reads [datasheet] (rated torque, bands, TE
    positions): no "[datasheet] has no effect" beside it; without it, the warning."""
    from corr_cad.run.scene.scene_text import no_effect_warnings

    data = {
        "errors": {"measured_profile": "m.csv"},
        "datasheet": {"transmission_error_positions_per_turn": 36},
    }
    assert not any("[datasheet]" in w for w in no_effect_warnings(data, ("inspection",), False))
    assert any("[datasheet]" in w for w in no_effect_warnings(data, ("dxf",), False))
