"""What the plots show: the figure's own data against independent computations.

Each plot function is run with ``plots._save`` replaced by a recorder, so the
test reads the lines, bars and patches matplotlib was given.
"""

from __future__ import annotations

import numpy as np
import pytest

from corr_cad import GearDesign, solve_forces
from corr_cad.export import plots
from corr_cad.geometry.profile import theoretical_profile, working_profile
from corr_cad.tolerance.checks import Checks

M0 = 1.1e5


@pytest.fixture
def figures(monkeypatch):
    got = []

    def record(fig, path):
        got.append(fig)
        return path

    monkeypatch.setattr(plots, "_save", record)
    yield got
    import matplotlib.pyplot as plt

    for f in got:
        plt.close(f)


@pytest.fixture(scope="module")
def res():
    return solve_forces(GearDesign(), M0, positions=104)


def _texts(fig) -> str:
    out = [t.get_text() for t in fig.texts]
    if fig._suptitle is not None:
        out.append(fig._suptitle.get_text())
    for ax in fig.axes:
        out += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        out += [t.get_text() for t in ax.texts]
        leg = ax.get_legend()
        if leg:
            out += [t.get_text() for t in leg.get_texts()]
    for leg in fig.legends:
        out += [t.get_text() for t in leg.get_texts()]
    return "\n".join(out)


def test_forces_png_shows_the_envelope_over_all_rollers(figures, res, tmp_path):
    d = GearDesign()
    plots.forces_png(res, tmp_path / "f.png", d, M0)
    (fig,) = figures
    ax1, ax2 = fig.axes
    lines = {ln.get_label(): ln for ln in ax1.get_lines()}
    order = np.argsort(res.crank_angles)
    # Envelope: the largest F_n of any roller at each position, not roller 1's.
    env = lines["max $F_n$ (inner gear) over all rollers"].get_ydata()
    np.testing.assert_array_equal(env, np.max(res.F_n[order], axis=1))
    r1 = lines["$F_n$ (inner gear), roller 1"].get_ydata()
    np.testing.assert_array_equal(r1, res.F_n[order, 0])
    assert np.any(env > r1)
    np.testing.assert_array_equal(
        lines["max $|F_s|$ (slot wall) over all rollers"].get_ydata(),
        np.max(np.abs(res.F_s[order]), axis=1),
    )
    p = {ln.get_label(): ln.get_ydata() for ln in ax2.get_lines()}
    np.testing.assert_array_equal(p["inner gear: max over rollers"], res.p_gear[order].max(1))
    np.testing.assert_array_equal(p["cam: max over rollers"], res.p_cam[order].max(1))
    np.testing.assert_array_equal(p["slot wall: max over rollers"], res.p_slot[order].max(1))
    text = _texts(fig)
    for must in ("z = 25", "Rj = 135 mm", "M0 = 1.1e+05 N*mm", "[N]", "[MPa]", "[deg]"):
        assert must in text, must
    k, j = np.unravel_index(np.argmax(res.F_n), res.F_n.shape)
    assert f"roller {j + 1} at" in text


def test_load_distribution_numbers_rollers_and_marks_the_eccentric(figures, res, tmp_path):
    d = GearDesign()
    k = 7
    ang = float(np.degrees(res.crank_angles[k]))
    plots.load_distribution_png(d, ang, res.F_j[k], res.F_n[k], res.F_s[k], tmp_path / "l.png", M0)
    (fig,) = figures
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert labels == [str(i) for i in range(1, 27)]
    # Roller i's tick sits at its slot angle (i - 1) * 360/26 deg, as the solver's psi says:
    # psi_i = crank angle - slot angle.
    ticks = np.degrees(ax.get_xticks())
    psi = np.degrees(res.psi[k])
    np.testing.assert_allclose(np.mod(ang - ticks - psi + 180, 360) - 180, 0, atol=1e-9)
    bars = {}
    for c in ax.containers:
        bars[c.get_label()] = np.array([b.get_height() for b in c])
    np.testing.assert_array_equal(bars["$F_n$ (inner gear)"], res.F_n[k])
    np.testing.assert_array_equal(bars["$F_j$ (cam)"], res.F_j[k])
    np.testing.assert_array_equal(bars["$|F_s|$ (slot wall)"], np.abs(res.F_s[k]))
    arrow = [a for a in ax.texts if getattr(a, "xy", None) is not None and a.get_text() == ""]
    assert arrow and arrow[0].xy[0] == pytest.approx(np.radians(ang))
    # The radial scale labels sit halfway between rollers 1 and 2, not on a bar.
    assert ax.get_rlabel_position() == pytest.approx(180 / 26)
    assert "eccentric" in _texts(fig) and "M0 = 1.1e+05 N*mm" in _texts(fig)


def test_preview_shades_the_material_not_the_bore(figures, tmp_path):
    d = GearDesign()
    plots.preview_png(d, working_profile(d), theoretical_profile(d), tmp_path / "p.png")
    (fig,) = figures
    ax = fig.axes[0]
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())
    h = img.shape[0]

    def colour(x, y):
        px, py = ax.transData.transform((x, y))
        return tuple(img[int(round(h - py)), int(round(px)), :3])

    white = (255, 255, 255)
    ring_rgb = colour(0.0, d.ring_outer_radius - 3.0)  # rim material
    cam_rgb = colour(0.0, 0.5 * (d.cam_bore_radius + d.cam_radius))  # cam web
    assert ring_rgb != white and cam_rgb != white and ring_rgb != cam_rgb
    # Not shaded: the crankshaft bore, and the clearance between cam, rollers and teeth.
    for x, y in ((0.5, 0.0), (-0.5, 0.0), (0.0, -0.5)):  # (the axis marker is at the centre)
        assert colour(x * d.cam_bore_radius, y * d.cam_bore_radius) == white
    gap = d.cam_radius + d.eccentricity + 1.0  # between cam and tooth tip at 90 deg
    assert colour(gap, 0.0) != ring_rgb
    # The legend is outside the axes (on the figure), the crank angle is stated.
    assert ax.get_legend() is None and fig.legends
    text = _texts(fig)
    assert "crank angle 0 deg" in text and "frame" in text


def test_interference_png_states_pass_or_fail(figures, tmp_path):
    allowance = {p: {"volume_mm3": 1e-3, "gap_mm": 2e-3} for p in ("ring", "cam", "frame")}
    rows = [
        {"crank_angle_deg": a, **{f"{p}_{q}": 1e-4 for p in allowance for q in ("volume", "gap")}}
        for a in (0.0, 90.0)
    ]
    plots.interference_png([0.0, 90.0], rows, list(allowance), allowance, tmp_path / "a.png")
    rows[1]["cam_volume"] = 0.5
    plots.interference_png([0.0, 90.0], rows, list(allowance), allowance, tmp_path / "b.png")
    ok, bad = (_texts(f) for f in figures)
    assert "PASS" in ok and "FAIL" not in ok and "FAIL" in bad
    assert "Allowance" in ok and "chord tolerance" in ok
    for f in figures:  # legends outside the data area
        for ax in f.axes:
            assert ax.get_legend().get_bbox_to_anchor().x0 > ax.bbox.x1 - 1


def test_montecarlo_png_percentiles_limits_nominal_and_no_spike(figures, tmp_path):
    rng = np.random.default_rng(3)
    n = 200
    metrics = {
        "peak_gear_force": rng.normal(5000, 500, n),
        "peak_pressure": rng.normal(2000, 100, n),
        "min_loaded_rollers": rng.integers(4, 12, n).astype(float),
        "backlash_arcmin": np.zeros(n),
    }
    checks = Checks(max_gear_force=5500.0, max_backlash_arcmin=1.0)
    summary = {
        "failure_probability": {
            "max_gear_force": float(np.mean(metrics["peak_gear_force"] > 5500)),
            "max_backlash_arcmin": 0.0,
        },
        "sensitivity": [
            {"tolerance": "roller_radius", "spearman": dict.fromkeys(metrics, 0.5), "score": 0.5}
        ],
    }
    nominal = {"peak_gear_force": 4000.0}
    plots.montecarlo_png(metrics, checks, tmp_path / "m.png", summary, nominal, GearDesign(), M0)
    (fig,) = figures
    ax = fig.axes[0]
    vlines = {ln.get_label(): ln.get_xdata()[0] for ln in ax.get_lines()}
    for q in (5, 50, 95, 99):
        v = np.percentile(metrics["peak_gear_force"], q)
        assert vlines[f"p{q} = {v:.4g}"] == pytest.approx(v)
    assert vlines["limit = 5500"] == 5500.0 and vlines["nominal = 4000"] == 4000.0
    pf = summary["failure_probability"]["max_gear_force"]
    assert ax.get_title() == f"P(fail) = {100 * pf:.1f} %"
    text = _texts(fig)
    # Constant backlash: said in words, not drawn as a one-pixel spike.
    assert "all 200 samples: 0" in text
    # Sensitivity bar chart: one bar per metric for the tolerance.
    sens = fig.axes[2]
    assert [t.get_text() for t in sens.get_yticklabels()] == ["roller radius"]
    assert len(sens.patches) == 4


def test_sweep_png_states_range_and_clipping(figures, tmp_path):
    pts = [
        {
            "value": v,
            "status": "ok",
            **dict.fromkeys(
                ["F_j_mean", "F_n_mean", "F_s_mean", "F_j_peak", "F_n_peak", "F_s_peak_to_peak"],
                1.0,
            ),
        }
        for v in np.linspace(7.0, 10.052981, 7)
    ]
    rng = {
        "source": "paper",
        "requested": [7.0, 20.0],
        "swept": [7.0, 10.052981],
        "clipped_low": None,
        "clipped_high": "undercut",
    }
    plots.sweep_png("roller_radius", pts, tmp_path / "s.png", rng, GearDesign(), M0)
    (fig,) = figures
    text = _texts(fig)
    assert "high end clipped at 10.053 mm (undercut)" in text and "7 .. 20 mm" in text
    assert "M0 = 1.1e+05 N*mm" in text
    for ax in fig.axes:  # few enough ticks that the labels cannot overlap
        assert len(ax.get_xticks()) <= 7


def test_bench_point_labels_never_overprint():
    import matplotlib.pyplot as plt

    from corr_cad.export.bench_plots import place_labels as _place_labels

    fig, ax = plt.subplots(figsize=(8, 5))
    # Points as in the solver-fidelity study: three nearly on top of each other.
    pts = [(0.015, 0.52, "rigid (no compliance)"), (0.0152, 0.58, "linear contact")]
    pts += [(0.0168, 0.585, "nonlinear contact"), (0.02, 1e-16, "exact"), (0.04, 1e-16, "1e-13")]
    ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o")
    _place_labels(ax, pts)
    fig.canvas.draw()
    boxes = [t.get_window_extent() for t in ax.texts]
    assert len(boxes) == len(pts)
    for i, a in enumerate(boxes):
        assert ax.bbox.y0 <= a.y0 and a.y1 <= ax.bbox.y1  # inside the axes
        for b in boxes[i + 1 :]:
            assert not a.overlaps(b)
    plt.close(fig)
