"""What the plots show: the figure's own data against independent computations.

Each plot function is run with ``plots._save`` replaced by a recorder, so the
test reads the lines, bars and patches matplotlib was given.
"""

from __future__ import annotations

import numpy as np
import pytest

from corr_cad import GearDesign, solve_forces
from corr_cad.export import plots, plots_tolerance
from corr_cad.figure_text import figure
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
    for must in ("z = 25", "Rj = 135 mm", "M0 = 110,000 N*mm", "[N]", "[MPa]", "[deg]"):
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
    # The radial scale labels sit halfway between two rollers, not on a bar.
    half = np.mod(ax.get_rlabel_position() / (360 / 26) - 0.5, 1.0)
    assert half == pytest.approx(0.0, abs=1e-9) or half == pytest.approx(1.0, abs=1e-9)
    assert "eccentric" in _texts(fig) and "M0 = 110,000 N*mm" in _texts(fig)


def _boxes(fig, texts):
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    return [t.get_window_extent(r) for t in texts if t.get_text() and t.get_visible()]


@pytest.mark.slow
@pytest.mark.parametrize("z, rj, r, e", [(31, 120.0, 5.5, 3.0), (25, 135.0, 8.0, 3.5)])
def test_load_distribution_labels_never_overprint(figures, tmp_path, z, rj, r, e):
    """The eccentric's label and arrow keep off the roller numbers and the radial scale.

    z = 31 peaks at a crank angle of 2.25 deg: the arrow ran through the scale
    (between rollers 1 and 2) and the label sat on the roller numbers.
    """
    d = GearDesign(tooth_count=z, cam_radius=rj, roller_radius=r, eccentricity=e)
    res = solve_forces(d, M0, positions=8 * (z + 1))
    peak = int(np.unravel_index(np.argmax(res.F_n), res.F_n.shape)[0])
    for k in sorted({peak, *range(0, len(res.crank_angles), 5)}):
        ang = float(np.degrees(res.crank_angles[k]))
        plots.load_distribution_png(d, ang, res.F_j[k], res.F_n[k], res.F_s[k], tmp_path / "l", M0)
        fig = figures.pop()
        ax = fig.axes[0]
        label = _boxes(fig, [t for t in ax.texts if t.get_text() == "eccentric"])[0]
        numbers = _boxes(fig, ax.get_xticklabels())
        scale = _boxes(fig, ax.get_yticklabels())
        assert not [b for b in numbers + scale if b.overlaps(label)], (z, ang)
        (arrow,) = [t for t in ax.texts if t.get_text() == ""]
        shaft = np.column_stack([np.full(60, arrow.xy[0]), np.linspace(0, arrow.xy[1], 60)])
        pts = ax.transData.transform(shaft)
        assert not [b for b in scale for p in pts if b.contains(*p)], (z, ang)
        import matplotlib.pyplot as plt

        plt.close(fig)


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
    plots_tolerance.montecarlo_png(
        metrics, checks, tmp_path / "m.png", summary, nominal, GearDesign(), M0
    )
    (fig,) = figures
    ax = fig.axes[0]
    vlines = {ln.get_label(): ln.get_xdata()[0] for ln in ax.get_lines()}
    for q in (5, 50, 95, 99):
        v = np.percentile(metrics["peak_gear_force"], q)
        assert vlines[f"p{q} = {figure(v)}"] == pytest.approx(v)
    assert vlines["limit = 5,500"] == 5500.0 and vlines["nominal = 4,000"] == 4000.0
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
    plots_tolerance.sweep_png("roller_radius", pts, tmp_path / "s.png", rng, GearDesign(), M0)
    (fig,) = figures
    text = _texts(fig)
    assert "high end clipped at 10.053 mm (undercut)" in text and "7 .. 20 mm" in text
    assert "M0 = 110,000 N*mm" in text
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


def _clearance_case(oversize):
    from corr_cad.geometry.clearance import clearance
    from corr_cad.geometry.deviations import ManufacturingErrors

    d = GearDesign()
    errs = [0.0] * d.roller_count
    errs[0], errs[24] = oversize, -0.003
    err = ManufacturingErrors(roller_radius_errors=tuple(errs), eccentricity_error=0.001)
    return d, clearance(d, np.radians(np.arange(360.0)), err if oversize else None)


def test_clearance_png_one_panel_per_contact_with_band_and_backlash_side(figures, tmp_path):
    d, clr = _clearance_case(0.002)
    plots.clearance_png(clr, tmp_path / "c.png", d)
    (fig,) = figures
    cam, ring, slot, neighbour = fig.axes
    for ax, arr in ((cam, clr.cam), (ring, clr.ring), (slot, clr.slot)):
        um = arr * 1e3
        lines = {
            ln.get_label().split(" ")[0]: ln for ln in ax.get_lines() if ln.get_label()[0] != "_"
        }
        # smallest (solid) and largest (dashed, the backlash side) over all rollers
        np.testing.assert_allclose(lines["smallest"].get_ydata(), um.min(axis=1), atol=1e-6)
        np.testing.assert_allclose(lines["largest"].get_ydata(), um.max(axis=1), atol=1e-6)
        assert lines["largest"].get_linestyle() == "--"
        assert "backlash" in lines["largest"].get_label()
        # the band is drawn and spans exactly smallest .. largest
        (band,) = [c for c in ax.collections if c.get_label() == "band: all rollers"]
        ys = np.concatenate([p.vertices[:, 1] for p in band.get_paths()])
        assert ys.min() == pytest.approx(um.min(), abs=1e-6)
        assert ys.max() == pytest.approx(um.max(), abs=1e-6)
        lo, hi = ax.get_ylim()
        assert lo < um.min() and hi > um.max() and hi - lo < 4 * (um.max() - um.min()) + 1
    # the design line, as on every plot
    assert "z = 25, Rj = 135 mm, r = 8 mm, e = 3.5 mm, l = 12 mm" in fig._suptitle.get_text()
    # the contacts in um; the neighbours' gap (17.6 mm: never a contact) in mm
    assert neighbour.get_ylabel() == "gap [mm]" and "never a contact" in neighbour.get_title()
    # each extreme named with its roller and angle from the summary
    plots.clearance_png(clr, tmp_path / "c2.png", d, summary=clr.summary())
    cam2 = figures[-1].axes[0]
    k = np.unravel_index(np.argmin(clr.cam), clr.cam.shape)
    (smallest,) = [ln for ln in cam2.get_lines() if ln.get_label().startswith("smallest")]
    assert f"(roller {k[1] + 1}, " in smallest.get_label()


def test_clearance_png_exact_contact_is_said_not_drawn_as_three_lines(figures, tmp_path):
    d, clr = _clearance_case(0.0)
    plots.clearance_png(clr, tmp_path / "c.png", d)
    (fig,) = figures
    for ax in fig.axes[:3]:
        assert [t.get_text() for t in ax.texts][0].startswith("exact contact: every roller")
        assert ax.get_ylim() == (-1.0, 1.0)
        assert len([ln for ln in ax.get_lines() if ln.get_label()[0] != "_"]) == 1


def _legend_covers_bars(ax) -> bool:
    fig = ax.figure
    fig.canvas.draw()
    box = ax.get_legend().get_window_extent(fig.canvas.get_renderer())
    for p in ax.patches:
        if p.get_data_transform() != ax.transData or p.get_height() <= 0:
            continue
        bar = p.get_window_extent()
        if bar.overlaps(box):
            return True
    return False


@pytest.mark.parametrize("beyond", [60, 300])  # some samples beyond 4000 MPa; all (z = 31)
def test_montecarlo_png_pressure_axis_and_whole_roller_counts(figures, tmp_path, beyond):
    """Pressures far beyond the 4000 MPa Hertz bound do not stretch the axis; the bound is
    drawn; roller counts get whole-number percentiles; no legend covers a bar."""
    rng = np.random.default_rng(5)
    n = 300
    metrics = {
        "peak_gear_force": rng.normal(9000, 2000, n),
        "peak_pressure": np.r_[
            rng.normal(3000, 400, n - beyond), rng.uniform(13000, 26000, beyond)
        ],
        "min_loaded_rollers": rng.integers(4, 28, n).astype(float),
        "backlash_arcmin": np.zeros(n),
    }
    checks = Checks(max_contact_pressure=4000.0, min_loaded_rollers=4)
    nominal = {"peak_pressure": 2642.0}
    plots_tolerance.montecarlo_png(metrics, checks, tmp_path / "m.png", None, nominal, GearDesign())
    (fig,) = figures
    ax = fig.axes[1]
    assert ax.get_xlabel() == "peak contact pressure [MPa]"
    lo, hi = ax.get_xlim()
    assert hi < 2 * 4000  # not out to the 26,000 MPa samples
    bound = [ln for ln in ax.get_lines() if "4000 MPa" in ln.get_label()]
    assert len(bound) == 1 and bound[0].get_xdata()[0] == 4000
    # every sample counted once: the bars on the axis plus the one off-scale bar
    counted = sum(p.get_height() for p in ax.patches if p.get_data_transform() == ax.transData)
    assert counted == n
    off = [c for c in ax.containers if "off scale" in c.get_label()]
    assert len(off) == 1 and len(off[0]) == 1
    count, cap = (float(w) for w in off[0].get_label().split()[::3][:2])
    assert off[0][0].get_height() == count == np.count_nonzero(metrics["peak_pressure"] > cap)
    assert cap < hi < 2 * cap
    # fewest loaded rollers: percentiles are sample values (whole rollers)
    rollers = fig.axes[3]
    pct = {
        ln.get_label().split(" = ")[0]: ln.get_label().split(" = ")[1]
        for ln in rollers.get_lines()
        if ln.get_label().startswith("p")
    }
    for q in (5, 50, 95, 99):
        want = np.percentile(metrics["min_loaded_rollers"], q, method="inverted_cdf")
        assert pct[f"p{q}"] == f"{want:g}" and float(pct[f"p{q}"]).is_integer()
    for a in (fig.axes[0], ax, rollers):
        assert not _legend_covers_bars(a)


def _sweep_points(values, curve):
    keys = ["F_j_mean", "F_n_mean", "F_s_mean", "F_j_peak", "F_n_peak", "F_s_peak_to_peak"]
    return [
        {"value": v, "status": "ok", **{k: curve(v, i) for i, k in enumerate(keys)}} for v in values
    ]


#: z = 31's roller-radius sweep, as run (N at 4.4 mm and the slope per mm): nearly flat
#: lines, the peak F_n one along the top where the legend used to sit.
Z31_SWEEP = [(1669.0, 0.5), (1933.0, -3.0), (972.0, -7.0), (2266.0, 3.0), (2827.0, -4.0)]
Z31_SWEEP += [(1748.0, -12.0)]


@pytest.mark.parametrize(
    "name, values, mark",
    [
        ("roller_radius", np.linspace(4.4, 5.5829, 7), 5.5),
        ("eccentricity_error", np.linspace(-0.02, 0.02, 7), 0.0),
        ("cam_radius_error", np.linspace(-0.02, 0.02, 7), 0.0),
    ],
)
def test_sweep_png_legend_off_the_data_and_design_marked(figures, tmp_path, name, values, mark):
    d = GearDesign(tooth_count=31, cam_radius=120.0, roller_radius=5.5, eccentricity=3.0)
    pts = _sweep_points(values, lambda v, i: Z31_SWEEP[i][0] + Z31_SWEEP[i][1] * (v - values[0]))
    rng = {"source": "default", "requested": [values[0], values[-1]], "swept": None}
    rng.update(swept=[values[0], values[-1]], clipped_low=None, clipped_high=None)
    plots_tolerance.sweep_png(name, pts, tmp_path / "s.png", rng, d, M0)
    (fig,) = figures
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    for ax in fig.axes:
        box = ax.get_legend().get_window_extent(r)
        for ln in ax.get_lines():
            xy = ax.transData.transform(np.column_stack([ln.get_xdata(), ln.get_ydata()]))
            if ln.get_label().startswith("design"):
                continue  # a vertical line over the whole axis height
            assert not [p for p in xy if box.contains(*p)], (name, ln.get_label())
        (design,) = [ln for ln in ax.get_lines() if ln.get_label().startswith("design")]
        assert design.get_xdata()[0] == pytest.approx(mark)


def test_montecarlo_roller_counts_are_whole_in_the_summary_and_the_plot(figures, tmp_path):
    """montecarlo_summary.json (and so the console) and the plot give the same whole numbers."""
    from corr_cad.tolerance.montecarlo import MonteCarloResult

    rng = np.random.default_rng(11)
    counts = rng.integers(9, 28, 300).astype(float)
    metrics = {
        "peak_gear_force": rng.normal(9000, 2000, 300),
        "peak_pressure": rng.normal(2000, 200, 300),
        "min_loaded_rollers": counts,
        "backlash_arcmin": np.zeros(300),
    }
    summary = MonteCarloResult(metrics, {"roller_radius": np.ones(300)}, True).summary(Checks())
    pct = summary["percentiles"]["min_loaded_rollers"]
    for q in (5, 50, 95, 99):
        assert pct[f"p{q}"] == np.percentile(counts, q, method="inverted_cdf")
        assert pct[f"p{q}"] in counts  # a sample value: a whole roller count
    plots_tolerance.montecarlo_png(metrics, Checks(), tmp_path / "m.png", summary)
    (fig,) = figures
    labels = [ln.get_label() for ln in fig.axes[3].get_lines() if ln.get_label()[:1] == "p"]
    assert labels == [f"p{q} = {pct[f'p{q}']:g}" for q in (5, 50, 95, 99)]


@pytest.mark.parametrize(("allowed", "colour"), [(0.05, "C2"), (0.001, "C3"), (None, "C3")])
def test_montecarlo_png_colours_p_fail_by_the_gate(figures, tmp_path, allowed, colour):
    """P(fail) = 0.5 % is green when the 5 % gate passes, red when a 0.1 % gate fails, and
    red without a gate (a failing sample, nothing allows it)."""
    from matplotlib.colors import to_rgba

    rng = np.random.default_rng(3)
    metrics = {"peak_gear_force": rng.normal(5000, 500, 200)}
    checks = Checks(max_gear_force=5500.0, max_failure_probability=allowed)
    summary = {"failure_probability": {"max_gear_force": 0.005}, "sensitivity": []}
    plots_tolerance.montecarlo_png(metrics, checks, tmp_path / "m.png", summary, None, None, 1.0)
    title = figures[0].axes[0].title
    assert title.get_text() == "P(fail) = 0.5 %"
    assert to_rgba(title.get_color()) == to_rgba(colour)
