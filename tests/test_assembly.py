"""Selective assembly (issue 20, item 4): the roller class for a ring, with its datasheet.

The reference is a hand calculation from the closed form (no corr_cad
import): rollers oversized by ``c`` ride the cam at ``L + c`` in their slots;
the frame turns, crank locked, until a roller disc (radius ``r + c``) meets
the ring (the locus offset by ``r + u``), found on a densely sampled locus.
"""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

Z, E, RJ, R = 25, 3.5, 135.0, 8.0
L = RJ + R
PITCH = 2 * math.pi / Z


def locus(t, ll=L):
    t = np.asarray(t, dtype=float)
    psi = Z * t
    s = E * np.cos(psi) + np.sqrt(ll * ll - (E * np.sin(psi)) ** 2)
    return np.stack([s * np.sin(t), s * np.cos(t)], -1)


def normal(t, ll=L):
    h = 1e-6
    d = (locus(t + h, ll) - locus(t - h, ll)) / (2 * h)
    n = np.stack([-d[..., 1], d[..., 0]], -1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


U = 0.006  # the synthetic ring is uniformly 6 um larger than the conjugate (material removed)


def _hand_backlash(u, c, x=0.0):
    """Free rotation (rad of output) of rollers oversized by ``c`` mm in a ring offset by ``u``.

    The roller rides the cam at ``L + c``; its disc (radius ``r + c``) meets
    the ring (locus offset by ``r + u``) when its centre is ``u - c`` beyond
    the locus. ``None`` when no frame angle fits (binding). The roller is
    centred in its slot: an undersize roller's slot play is not in it.
    """
    from scipy.optimize import brentq

    def beyond(dl):
        phi = (Z + 1) * x
        th = np.arange(Z + 1) * 2 * math.pi / (Z + 1)
        a = x + dl + th
        g = a - phi
        s = E * np.cos(g) + np.sqrt((L + c) ** 2 - (E * np.sin(g)) ** 2)
        h = np.stack([s * np.sin(a), s * np.cos(a)], -1)
        worst = -np.inf
        for k in range(Z + 1):
            pts = locus(np.linspace(a[k] - 0.01, a[k] + 0.01, 20001))
            d = np.hypot(pts[:, 0] - h[k, 0], pts[:, 1] - h[k, 1])
            j = int(np.argmin(d))
            worst = max(worst, d[j] if np.hypot(*h[k]) > np.hypot(*pts[j]) else -d[j])
        return worst - (u - c)

    if beyond(0.0) >= 0:
        return None
    return brentq(beyond, 1e-8, 1e-2, xtol=1e-12) - brentq(beyond, -1e-2, -1e-8, xtol=1e-12)


@pytest.mark.slow
def test_selective_assembly_picks_the_class_for_a_measured_ring(tmp_path):
    classes, target = [-2.0, 0.0, 2.0, 4.0], 0.3
    t = np.concatenate(
        [(np.arange(60) + 0.5) / 60 * PITCH - PITCH / 2 + k * PITCH for k in range(Z)]
    )
    pts = locus(t) + (R + U) * normal(t)
    (tmp_path / "cmm.csv").write_text(
        "x,y\n" + "\n".join(f"{x:.10f},{y:.10f}" for x, y in pts) + "\n"
    )
    (tmp_path / "s.toml").write_text(
        '[export]\nformats = ["datasheet", "report"]\n[load]\ninput_torque = 1.1e5\n'
        '[errors]\nmeasured_profile = "cmm.csv"\n'
        "[datasheet]\npositions_per_mesh = 2\ntransmission_error_positions_per_turn = 4\n"
        f"[assembly]\nroller_classes_um = {classes}\ntarget_backlash_arcmin = {target}\n"
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    a = json.loads((tmp_path / "out" / "assembly.json").read_text())
    arcmin = 10800 / math.pi
    hand = {c: _hand_backlash(U, c * 1e-3) for c in classes}
    for row in a["classes"]:
        h = hand[row["class_um"]]
        assert row["binds"] == (h is None), (row, h)
        if h is not None and row["class_um"] >= 0:
            assert row["backlash_arcmin"]["max"] == pytest.approx(h * arcmin, rel=1e-2)
        elif h is not None:  # an undersize roller also has play in its slot: more free rotation
            assert row["backlash_arcmin"]["max"] > h * arcmin
    ok = {c: h for c, h in hand.items() if h is not None and h * arcmin <= target}
    assert a["chosen_class_um"] == min(ok, key=ok.get) == 2.0
    html = (tmp_path / "out" / "report.html").read_text()
    assert "Selective assembly (measured ring)" in html and "2 (chosen)" in html


@pytest.mark.slow
def test_selective_assembly_without_a_fitting_class_exits_1(tmp_path):
    (tmp_path / "s.toml").write_text(
        '[export]\nformats = ["datasheet"]\n[load]\ninput_torque = 1.1e5\n'
        "[datasheet]\npositions_per_mesh = 2\ntransmission_error_positions_per_turn = 4\n"
        "[modification]\nequidistant_mm = 0.01\n"
        "[assembly]\nroller_classes_um = [-2.0, 0.0]\ntarget_backlash_arcmin = 0.3\n"
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 1, r.stderr
    assert "selective assembly failed" in r.stderr and "buy larger rollers" in r.stderr
    a = json.loads((tmp_path / "out" / "assembly.json").read_text())
    assert a["chosen_class_um"] is None
