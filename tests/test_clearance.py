"""Exact clearance over the cycle (issue 11, item 1).

Independent checks: the roller centres and the working profile are rebuilt
here from the closed form (s = e cos psi + sqrt(L^2 - e^2 sin^2 psi),
psi = z t, point s (sin t, cos t), working profile = outer offset by r) and
distances are brute-forced against a dense sampling; the solver's initial
gaps are compared contact by contact; the mesh booleans at a few positions.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from corr_cad.geometry.clearance import clearance, distance_to_working_profile
from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
from corr_cad.mechanics.row.solver import roller_geometry

R = 26


def _locus_xy(t, z, e, L):
    psi = z * t
    s = e * np.cos(psi) + np.sqrt(L * L - (e * np.sin(psi)) ** 2)
    return s * np.sin(t), s * np.cos(t)


def _working_xy(t, z, e, L, r, h=1e-6):
    """Outer offset by r, normal from a central difference of the closed form."""
    x, y = _locus_xy(t, z, e, L)
    xp, yp = _locus_xy(t + h, z, e, L)
    xm, ym = _locus_xy(t - h, z, e, L)
    tx, ty = xp - xm, yp - ym
    n = np.hypot(tx, ty)
    return x - r * ty / n, y + r * tx / n


@pytest.fixture(scope="session")
def nominal_3600(prototype):
    return clearance(prototype, 2 * np.pi * np.arange(3600) / 3600)


def test_nominal_prototype_is_in_exact_contact(nominal_3600):
    c = nominal_3600
    assert c.cam.shape == (3600, R)
    assert np.abs(c.cam).max() <= 1e-9
    assert np.abs(c.ring).max() <= 1e-9
    assert np.abs(c.slot).max() <= 1e-9
    assert c.neighbour.min() > 10.0  # the rollers never touch each other


def test_one_roller_2um_oversize(prototype, nominal_3600):
    per = [0.0] * R
    per[6] = 0.002
    err = ManufacturingErrors(roller_radius_errors=per)
    c = clearance(prototype, nominal_3600.crank_angles, err)
    for contact in (c.cam, c.ring):
        assert np.abs(contact[:, 6] + 0.002).max() <= 0.05e-3
    others = [i for i in range(R) if i != 6]
    for name in ("cam", "ring", "slot"):
        assert np.array_equal(getattr(c, name)[:, others], getattr(nominal_3600, name)[:, others])
    # The slot is made for the nominal roller: 2 um of interference on it.
    assert np.abs(c.slot[:, 6] + 0.002).max() <= 1e-9
    # It and its two neighbours see 2 um less between them; nobody else changes.
    d = c.neighbour - nominal_3600.neighbour
    assert np.abs(d[:, 6] + 0.002).max() <= 1e-9  # its nearer neighbour is 2 um closer
    assert np.all((d[:, [5, 7]] >= -0.002 - 1e-9) & (d[:, [5, 7]] <= 1e-12))
    far = [i for i in range(R) if i not in (5, 6, 7)]
    assert np.array_equal(c.neighbour[:, far], nominal_3600.neighbour[:, far])


@pytest.mark.slow
def test_distance_against_brute_force_dense_sampling(prototype):
    d = prototype
    z, e, L, r = d.tooth_count, d.eccentricity, d.link_length, d.roller_radius
    rng = np.random.default_rng(5)
    t = rng.uniform(0, 2 * np.pi, 40)
    off = rng.uniform(-0.05, 0.05, 40)
    x, y = _locus_xy(t, z, e, L)
    rad = np.hypot(x, y)
    q = np.stack([x * (1 + off / rad), y * (1 + off / rad)], axis=-1)
    got = distance_to_working_profile(d, q)
    for k in range(len(t)):
        tt = t[k] + np.linspace(-0.02, 0.02, 400_001)
        wx, wy = _working_xy(tt, z, e, L, r)
        brute = np.hypot(wx - q[k, 0], wy - q[k, 1]).min()
        # Sign: the roller centre is inside the working profile (free space).
        assert got[k] == pytest.approx(brute, abs=2e-8)


ERROR_CASES = {
    "cam_radius": ManufacturingErrors(cam_radius_error=0.004),
    "eccentricity": ManufacturingErrors(eccentricity_error=-0.003),
    "roller_uniform": ManufacturingErrors(roller_radius_error=-0.002),
    "roller_per": ManufacturingErrors(
        roller_radius_errors=tuple(0.001 * np.sin(np.arange(R)).round(6))
    ),
    "slot_angles": ManufacturingErrors(
        slot_angle_errors=tuple(math.radians(0.01) * np.cos(3 * np.arange(R)))
    ),
    "cam_phase": ManufacturingErrors(cam_phase_error=math.radians(0.02)),
    "profile_harmonics": ManufacturingErrors(
        profile_deviation=harmonic_deviation([[2, 0.003, 10.0], [25, 0.001, 0.0]])
    ),
    "all_but_profile": ManufacturingErrors(
        cam_radius_error=0.002,
        eccentricity_error=0.001,
        roller_radius_error=-0.001,
        roller_radius_errors=tuple(0.001 * np.cos(np.arange(R))),
        slot_angle_errors=tuple(math.radians(0.005) * np.sin(np.arange(R))),
        cam_phase_error=math.radians(-0.01),
    ),
}


@pytest.mark.parametrize("kind", sorted(ERROR_CASES))
def test_every_error_kind_matches_the_solver_initial_gaps(prototype, kind):
    err = ERROR_CASES[kind]
    ang = 2 * np.pi * np.arange(72) / 72
    c = clearance(prototype, ang, err)
    geo = roller_geometry(prototype, ang, err)
    # The solver's effective gap g_j + rho_n g_n - |rho_s| c_s, contact by contact.
    g = -c.cam + geo.rho_n * -c.ring - np.abs(geo.rho_s) * np.maximum(c.slot, 0.0)
    assert np.abs(g - geo.gap).max() <= 1e-12 + 1e-9 * np.abs(geo.gap).max()
    assert np.any(np.abs(geo.gap) > 1e-4) or kind == "cam_phase"


def _run(cli_args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", *cli_args], cwd=cwd, capture_output=True, text=True
    )


def test_cli_default_exact_clearance_on_a_real_folder(tmp_path):
    (tmp_path / "notes.txt").write_text("keep me")
    (tmp_path / "s.toml").write_text('[export]\nformats = ["interference"]\n')
    p = _run(["run", "s.toml", "--out", "out"], tmp_path)
    assert p.returncode == 0, p.stderr
    out = tmp_path / "out"
    assert (tmp_path / "notes.txt").read_text() == "keep me"
    assert not (out / "interference.csv").exists()
    with open(out / "clearance.csv", newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == [
        "crank_angle_deg",
        "roller",
        "cam_clearance_mm",
        "ring_clearance_mm",
        "slot_clearance_mm",
        "neighbour_clearance_mm",
    ]
    assert len(rows) == 1 + 3600 * R
    body = np.array(rows[1:], dtype=float)
    assert np.abs(body[:, 2:5]).max() <= 1e-9
    m = json.loads((out / "manifest.json").read_text())
    assert [s["name"] for s in m["stages"]] == ["undercut", "clearance"]  # no mesh
    assert m["clearance"]["positions"] == 3600
    assert m["clearance"]["working_contacts_max_abs_mm"] <= 1e-9
    assert {"clearance.csv", "clearance.png"} <= set(m["files"])


@pytest.mark.slow
def test_cli_both_methods_agree_for_an_oversize_roller(tmp_path):
    per = [0.0] * R
    per[2] = 0.05
    per[9] = -0.01
    (tmp_path / "s.toml").write_text(
        '[export]\nformats = ["interference"]\ninterference_method = "both"\n'
        f"interference_positions = 2\n[errors]\nroller_radius_errors = {per}\n"
    )
    p = _run(["run", "s.toml", "--out", "out"], tmp_path)
    assert p.returncode == 0, p.stderr
    m = json.loads((tmp_path / "out" / "manifest.json").read_text())
    agreement = m["interference"]["agreement_with_exact"]
    assert agreement["agree"], agreement["disagreements"]
    assert agreement["contacts_compared"] == 2 * R * 3
    assert not m["interference"]["ok"]  # the mesh sees the oversize roller too
    c = m["clearance"]
    assert c["ring"]["min_roller"] == 3 and c["ring"]["min_mm"] == pytest.approx(-0.05, abs=1e-9)
    assert c["ring"]["max_roller"] == 10 and c["ring"]["max_mm"] == pytest.approx(0.01, abs=1e-9)


def test_bad_interference_method_is_refused(tmp_path):
    (tmp_path / "s.toml").write_text('[export]\nformats = ["interference"]\n')
    (tmp_path / "b.toml").write_text(
        '[export]\nformats = ["interference"]\ninterference_method = "fast"\n'
    )
    p = _run(["run", "b.toml", "--out", "out"], tmp_path)
    assert p.returncode == 2
    assert "interference_method" in p.stderr and "fast" in p.stderr and "exact" in p.stderr
    assert "Traceback" not in p.stderr
    assert not (tmp_path / "out").exists()


def test_neighbour_clearance_is_the_nearer_of_all_other_rollers(prototype):
    """Each roller's neighbour clearance is to its *nearest* other roller (brute force).

    The centres are placed here from the closed form (slot ``k`` at polar angle
    ``theta = k 2 pi / (z + 1)`` in the frame, on the gear at ``t = phi / z +
    theta``, so ``psi = z t``; distance ``s`` along the slot), the radii
    carry a per-roller scatter, and every pair is measured: the nearer and the
    farther neighbour differ by more than 10 um, so taking the farther shows.
    """
    d = prototype
    z, e, L, r = d.tooth_count, d.eccentricity, d.link_length, d.roller_radius
    per = tuple(0.004 * np.sin(1.7 * np.arange(R) + 0.3).round(6))
    err = ManufacturingErrors(roller_radius_errors=per)
    phi = 2 * np.pi * np.arange(90) / 90
    c = clearance(d, phi, err)
    theta = 2 * np.pi * np.arange(R) / R
    psi = z * (phi[:, None] / z + theta[None, :])
    s = e * np.cos(psi) + np.sqrt(L * L - (e * np.sin(psi)) ** 2)
    x, y = s * np.sin(theta), s * np.cos(theta)  # (P, R)
    radii = r + np.array(per)
    gap = np.hypot(x[:, :, None] - x[:, None, :], y[:, :, None] - y[:, None, :])
    gap = gap - radii[None, :, None] - radii[None, None, :]
    gap[:, np.arange(R), np.arange(R)] = np.inf  # not to itself
    nearest = gap.min(axis=2)
    assert np.abs(c.neighbour - nearest).max() <= 1e-9
    # The two neighbours differ (else the nearer and the farther could not be told apart).
    k = np.arange(R)
    assert np.abs(gap[:, k, (k + 1) % R] - gap[:, k, k - 1]).max() > 0.01
