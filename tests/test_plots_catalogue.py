"""Plots that show what was computed, in catalogue numbers.

Each plot function runs with ``plots._save`` replaced by a recorder, so the
test reads what matplotlib was given: the panels, labels, legends and their
places, the tick labels.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.export import plots, plots_tolerance
from corr_cad.tolerance.checks import Checks
from corr_cad.tolerance.mc_datasheet import binding_probability

SCI = re.compile(r"\d[eE][+-]?\d")


@pytest.fixture
def figures(monkeypatch):
    got = []

    def record(fig, path):
        got.append(fig)
        return path

    from corr_cad.export import datasheet_plots, modification_plots

    for module in (plots, datasheet_plots, modification_plots):
        if hasattr(module, "_save"):
            monkeypatch.setattr(module, "_save", record)
    yield got
    import matplotlib.pyplot as plt

    for f in got:
        plt.close(f)


def _all_text(fig) -> list[str]:
    fig.canvas.draw()
    out = [t.get_text() for t in fig.texts]
    for ax in fig.axes:
        out += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        out += [t.get_text() for t in ax.texts]
        out += [t.get_text() for t in ax.get_xticklabels() + ax.get_yticklabels()]
        leg = ax.get_legend()
        if leg:
            out += [t.get_text() for t in leg.get_texts()]
    for leg in fig.legends:
        out += [t.get_text() for t in leg.get_texts()]
    return out


def _mc_metrics(n=300, seed=4):
    rng = np.random.default_rng(seed)
    binds = rng.random(n) < 0.1
    return {
        "peak_gear_force": rng.normal(9000, 900, n),
        "peak_pressure": rng.normal(2000, 150, n),
        "min_loaded_rollers": rng.integers(5, 9, n).astype(float),
        "backlash_arcmin": rng.normal(0.9, 0.1, n),
        "lost_motion_arcmin": rng.normal(0.95, 0.1, n),
        "torsional_rigidity_Nm_per_arcmin": rng.normal(21256.0, 900.0, n),
        "transmission_error_arcsec": rng.normal(6.0, 1.5, n),
        "binding_pressure_MPa": np.where(binds, rng.uniform(4000, 6000, n), 0.0),
    }, binds


def test_montecarlo_png_shows_the_datasheet_metrics_and_binding(figures, tmp_path):
    metrics, binds = _mc_metrics()
    summary = {
        "binding_probability": binding_probability(binds),
        "failure_probability": {"min_torsional_rigidity_Nm_per_arcmin": 0.02},
        "sensitivity": [
            {"tolerance": "roller_radius", "spearman": dict.fromkeys(metrics, 0.3), "score": 0.3}
        ],
    }
    checks = Checks(min_torsional_rigidity_Nm_per_arcmin=19000.0, max_lost_motion_arcmin=1.2)
    plots_tolerance.montecarlo_png(
        metrics, checks, tmp_path / "m.png", summary, None, GearDesign(), 1.1e5, None, 4000.0
    )
    (fig,) = figures
    labelled = {ax.get_xlabel(): ax for ax in fig.axes if ax.get_xlabel()}
    for name in metrics:  # one panel each: the sensitivity is ranked over all of them
        assert plots_tolerance._LABEL[name] in labelled
    sens = labelled["Spearman rank correlation with |drawn error| [-]"]
    assert len(sens.patches) == len(metrics)
    rig = labelled["torsional rigidity [N*m/arcmin]"]
    assert "limit = 19,000" in [t.get_text() for t in rig.get_legend().get_texts()]
    assert rig.get_title() == "P(fail) = 2.0 %"
    bind = labelled["binding preload pressure [MPa]"]
    assert bind.get_title().startswith(f"P(binds) = {100 * binds.mean():.3g} %")
    assert any(ln.get_xdata()[0] == 4000.0 for ln in bind.get_lines())
    # integer metric: whole-number ticks
    rollers = labelled["fewest loaded rollers [-]"]
    ticks = [t for t in rollers.get_xticks() if rollers.get_xlim()[0] <= t <= rollers.get_xlim()[1]]
    assert ticks and all(float(t).is_integer() for t in ticks)
    # legends below their panels: off the bars, the bands and the percentile lines
    fig.canvas.draw()
    for ax in labelled.values():
        leg = ax.get_legend()
        if ax is sens or leg is None:
            continue
        assert leg.get_window_extent().y1 < ax.get_window_extent().y0, ax.get_xlabel()
    text = _all_text(fig)
    assert not [t for t in text if SCI.search(t)], [t for t in text if SCI.search(t)]
    assert any("21," in t for t in text)  # thousands separated


@pytest.fixture(scope="module")
def sheet():
    from corr_cad.geometry.deviations import ManufacturingErrors
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet

    spec = DatasheetSpec(
        rated_torque=2.86e6,
        positions_per_mesh=4,
        transmission_error_positions_per_turn=26,
        series_rigidity_Nm_per_arcmin=12000.0,
    )
    errors = ManufacturingErrors(roller_radius_errors=tuple([-0.0043] * 25 + [-0.002]))
    return datasheet(GearDesign(), spec, errors=errors)


def test_hysteresis_png_marks_the_catalogue_figures_where_they_are(figures, sheet, tmp_path):
    from corr_cad.export.datasheet_plots import hysteresis_png
    from corr_cad.figure_text import figure
    from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD

    hysteresis_png(sheet, tmp_path / "h.png", GearDesign())
    (fig,) = figures
    full, zoom = fig.axes[:2]
    fig_ = sheet.figures()
    T_R = fig_["rated_torque_Nm"]
    # the secant (the thick green line) stops at the rated torque
    secant = [ln for ln in full.get_lines() if ln.get_linewidth() == 4]
    assert len(secant) == 1 and np.max(np.abs(secant[0].get_ydata())) <= T_R * (1 + 1e-12)
    # the rigidity label: the datasheet's catalogue figure, every number with its unit
    label = next(t.get_text() for t in full.texts if t.get_text().startswith("rigidity"))
    cat = fig_["torsional_rigidity_Nm_per_arcmin"]["catalogue"]
    assert label.startswith(f"rigidity {figure(cat)} N*m/arcmin")
    assert label.count("N*m/arcmin") == 2 and "contacts alone" in label
    # the backlash label sits on the red bar it names, above zero torque, below the band
    bar = next(
        ln for ln in zoom.get_lines() if isinstance(ln.get_color(), str) and ln.get_color() == "C3"
    )
    text = next(t for t in zoom.texts if t.get_text().startswith("backlash"))
    x, y = text.get_position()
    lo, hi = sorted(bar.get_xdata())
    assert lo < x < hi and 0.0 < y < fig_["lost_motion_arcmin"]["band"] * T_R
    assert text.get_text() == f"backlash {figure(fig_['backlash_arcmin']['max'])} arcmin " + (
        "(at zero torque)"
    )
    assert abs(hi - lo - fig_["backlash_arcmin"]["max"]) < 1e-9 * ARCMIN_PER_RAD
    # the curves cross both labels near zero torque: each stands on a white box above them
    top = max(ln.get_zorder() for ln in zoom.get_lines())
    for start in ("backlash", "lost motion"):
        t = next(t for t in zoom.texts if t.get_text().startswith(start))
        box = t.get_bbox_patch()
        assert box is not None and box.get_facecolor()[:3] == (1.0, 1.0, 1.0), start
        assert box.get_facecolor()[3] >= 0.8 and t.get_zorder() > top, start
    # every position drawn above the marked position's underlay, in its own colour
    under = [ln for ln in full.get_lines() if ln.get_alpha() == 0.35]
    each = [ln for ln in full.get_lines() if ln.get_linewidth() == 0.9]
    assert len(under) == 1 and len(each) == sheet.windup.shape[1]
    assert all(ln.get_zorder() > under[0].get_zorder() for ln in each)
    assert len({ln.get_color() if isinstance(ln.get_color(), str) else tuple(ln.get_color())
                for ln in each}) == len(each)  # fmt: skip
    text = _all_text(fig)
    assert not [t for t in text if SCI.search(t)], [t for t in text if SCI.search(t)]


def test_hysteresis_png_title_with_friction_names_the_loop_not_coinciding_branches(
    figures, sheet, tmp_path
):
    from corr_cad.export.datasheet_plots import hysteresis_png

    hysteresis_png(sheet, tmp_path / "a.png", GearDesign())
    from matplotlib.colors import same_color

    T = np.asarray(sheet.torques, dtype=float)
    theta = sheet.windup[:, 0]
    loop = {"torques": T, "output_angle": 0.0, "frictionless": theta,
            "rising": theta - 1e-5, "falling": theta + 1e-5}  # fmt: skip
    hysteresis_png(sheet, tmp_path / "b.png", GearDesign(), friction_width_arcmin=0.6262, loop=loop)
    plain, rubbing = ("\n".join(t.get_text() for t in f.texts) for f in figures)
    assert "branches coincide: no friction in the model" in plain
    # with [friction] the figure must not claim there is none; it names the loop's width
    assert "no friction" not in rubbing and "coincide" not in rubbing
    assert "opens the loop (red) by up to 0.6262 arcmin at +-$T_R$" in rubbing
    # both branches drawn on both panels, in arcmin against N*m
    arcmin = 10800 / np.pi
    for ax in figures[1].axes[:2]:
        red = [ln for ln in ax.get_lines() if same_color(ln.get_color(), "C3")]
        xs = [np.asarray(ln.get_xdata()) for ln in red]
        assert any(np.allclose(x, (theta - 1e-5) * arcmin) for x in xs)
        assert any(np.allclose(x, (theta + 1e-5) * arcmin) for x in xs)


def test_transmission_error_png_each_direction_about_its_mean_on_its_own_scale(
    figures, sheet, tmp_path
):
    from corr_cad.export.datasheet_plots import transmission_error_png
    from corr_cad.mechanics.row.windup import ARCSEC_PER_RAD

    transmission_error_png(sheet, tmp_path / "t.png", GearDesign())
    (fig,) = figures
    axes = np.array(fig.axes).reshape(2, 2)
    for row, te in ((0, sheet.te_forward), (1, sheet.te_reverse)):
        y = te * ARCSEC_PER_RAD
        ptp = float(np.ptp(y))
        first = axes[row, 1].get_lines()[0].get_ydata()
        assert np.all(np.abs(first) <= ptp + 1e-12)  # the mean removed
        lo, hi = axes[row, 0].get_ylim()
        assert ptp / (hi - lo) > 0.5  # the ripple fills its own axis
        assert f"about its mean {figure_of(float(y.mean()))} arcsec" in axes[row, 0].get_title()


def figure_of(v):
    from corr_cad.figure_text import figure

    return figure(v)


def _candidate(eq, sh, backlash, binding, solved=False, pressure=None):
    row = {
        "valid": True,
        "equidistant_mm": eq,
        "shift_mm": sh,
        "backlash_arcmin": {"p95": {"value": backlash}},
        "binding_probability": {"value": binding},
        "force_solved": solved,
    }
    if solved:
        row["peak_pressure_MPa"] = {"p95": {"value": pressure}}
    return row


def test_modification_tradeoff_scatters_labels_shades_and_flags_the_edge(figures, tmp_path):
    from corr_cad.export.modification_plots import tradeoff_png
    from corr_cad.run.stages.stages_modification import range_edges

    cands = [
        _candidate(0.0, 0.02, 1.8, 0.0, True, 2708.0),
        _candidate(0.01, 0.01, 1.94, 0.0, True, 2735.0),
        _candidate(0.02, 0.0, 1.2, 0.0, True, 2650.0),
        _candidate(0.0, -0.01, 0.0, 1.0),
    ]
    res = {
        "targets": {
            "backlash_percentile": 95.0,
            "target_backlash_arcmin": 2.0,
            "max_binding_probability": 0.05,
        },
        "candidates": cands,
        "chosen": cands[0],
        "objective": "peak_pressure",
        "family": "equidistant+shift",
        "samples": 60,
        "met": True,
    }
    md = {
        "family": "equidistant+shift",
        "equidistant_range_mm": [0.0, 0.03],
        "shift_range_mm": [-0.01, 0.02],
    }
    edges = range_edges(md, cands[0])
    tradeoff_png(res, tmp_path / "t.png", GearDesign(), edges)
    (fig,) = figures
    a1, a2 = fig.axes
    # different candidates are points, never joined by a line; each carries its amounts
    assert not [ln for ln in a2.get_lines() if len(ln.get_xdata()) > 1]
    notes = sorted(t.get_text() for t in a2.texts)
    assert notes == ["eq 0 / sh 0.02", "eq 0.01 / sh 0.01", "eq 0.02 / sh 0"]
    # the feasible region: up to both targets
    (box,) = [p for p in a1.patches if p.get_label() == "feasible: both targets met"]
    x0, y0 = box.get_xy()
    assert x0 + box.get_width() == pytest.approx(2.0)
    assert y0 + box.get_height() == pytest.approx(0.05)
    # the choice at the top of its range: on the plot, and in the console's warnings
    assert edges == [
        "shift_mm = 0.02 at the top of shift_range_mm = [-0.01, 0.02]; widen it, e.g. "
        "shift_range_mm = [-0.01, 0.035]"
    ]
    assert any(edges[0] in t.get_text() for t in fig.texts)
    from corr_cad.run.console import warnings

    (line,) = warnings({"modification_design": {"at_range_edge": edges}})
    assert line.startswith("modification design: the chosen shift_mm = 0.02 at the top")


def test_range_edges_top_always_bottom_unless_zero():
    from corr_cad.run.stages.stages_modification import range_edges

    md = {
        "family": "equidistant+shift",
        "equidistant_range_mm": [0.0, 0.03],
        "shift_range_mm": [-0.01, 0.02],
    }
    assert range_edges(md, {"equidistant_mm": 0.0, "shift_mm": 0.005}) == []  # 0: natural end
    low = range_edges(md, {"equidistant_mm": 0.01, "shift_mm": -0.01})
    assert len(low) == 1 and "bottom of shift_range_mm" in low[0]
    top = range_edges(md, {"equidistant_mm": 0.03, "shift_mm": 0.0})
    assert len(top) == 1 and "equidistant_mm = 0.03 at the top" in top[0]
    assert range_edges({**md, "steps": 1}, {"equidistant_mm": 0.03, "shift_mm": 0.02}) == []
    free = {**md, "family": "free"}
    got = range_edges(free, {"equidistant_mm": 0.0, "shift_mm": 0.0, "normal_mm": [0, 0.03, 0]})
    assert len(got) == 1 and got[0].startswith("normal_mm = 0.03 at the top")


def test_preview_png_labels_clear_legend_complete_and_a_modified_ring_named(figures, tmp_path):
    from corr_cad.geometry.profile import theoretical_profile, working_profile

    d = GearDesign()
    plots.preview_png(
        d,
        working_profile(d),
        theoretical_profile(d),
        tmp_path / "p.png",
        modification="equidistant +0.01 mm, shift +0.005 mm",
    )
    (fig,) = figures
    fig.canvas.draw()
    ax = fig.axes[0]
    labels = [t for t in ax.texts if t.get_text().startswith("roller")]
    assert [t.get_text() for t in labels] == ["roller 1", "roller 2"]
    outer = max(d.ring_outer_radius, d.frame_outer_radius)
    boxes = []
    for t in labels:  # outside the ring (and so off the cam), inside the axes, apart
        assert np.hypot(*t.get_position()) > outer
        box = t.get_window_extent()
        assert ax.get_window_extent().contains(box.x0, box.y0)
        boxes.append(box)
    assert not boxes[0].overlaps(boxes[1])
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "frame plate rims (frame plane)" in legend
    assert "working profile (gear, modified: equidistant +0.01 mm, shift +0.005 mm)" in legend
    assert "modified ring: equidistant +0.01 mm" in fig._suptitle.get_text()


def test_clearance_png_one_unit_and_no_dead_space(figures, tmp_path):
    from corr_cad.geometry.clearance import clearance
    from corr_cad.geometry.deviations import ManufacturingErrors

    d = GearDesign()
    err = ManufacturingErrors(roller_radius_error=-0.002)  # 2 um play everywhere, no contact
    clr = clearance(d, np.radians(np.arange(0.0, 360.0, 4.0)), err)
    plots.clearance_png(clr, tmp_path / "c.png", d)
    (fig,) = figures
    fig.canvas.draw()
    assert {ax.get_ylabel() for ax in fig.axes[:3]} == {"clearance [um]"}
    assert fig.axes[3].get_ylabel() == "gap [mm]"  # 17.6 mm between rollers, not 17,636 um
    for ax, arr, unit in zip(
        fig.axes, (clr.cam, clr.ring, clr.slot, clr.neighbour), (1e3, 1e3, 1e3, 1.0), strict=True
    ):
        um = arr * unit
        lo, hi = ax.get_ylim()
        # the band far from zero fills its axis: no empty strip down to zero
        assert 0.0 < lo < um.min() and hi > um.max()
        leg = ax.get_legend().get_window_extent()  # inside the panel, above the band
        box = ax.get_window_extent()
        assert box.x0 <= leg.x0 and leg.x1 <= box.x1
        y_band_top = ax.transData.transform((0.0, um.max()))[1]
        assert leg.y0 >= y_band_top - 1
    assert max(ax.get_position().x1 for ax in fig.axes) > 0.9  # no column left for legends
    neighbour = fig.axes[3]
    smallest = next(ln for ln in neighbour.get_lines() if ln.get_label().startswith("smallest"))
    assert smallest.get_label() == f"smallest {figure_of(float(clr.neighbour.min()))} mm"


def _class(c, bmin, bmax, binds, inter, meets):
    return {
        "class_um": c,
        "binds": binds,
        "interference_um": inter,
        "backlash_arcmin": {"min": bmin, "mean": 0.5 * (bmin + bmax), "max": bmax},
        "meets_target": meets,
    }


def test_assembly_png_each_class_against_the_target(figures, tmp_path):
    from corr_cad.export.datasheet_plots import assembly_png
    from corr_cad.run.folder.names import is_output_name

    res = {
        "ring": "modified ring, equidistant +0.004 mm",
        "target_backlash_arcmin": 0.6,
        "chosen_class_um": 0.0,
        "classes": [
            _class(-2.0, 0.77, 0.78, False, -8.0, False),
            _class(0.0, 0.35, 0.3552, False, -4.0, True),
            _class(2.0, 0.0, 0.0, True, 1.3e-11, False),
            _class(4.0, 0.0, 0.0, True, 4.0, False),
        ],
    }
    assembly_png(res, tmp_path / "assembly.png", GearDesign())
    (fig,) = figures
    a1, a2 = fig.axes
    bars = [p for p in a1.patches if p.get_width() > 0]
    assert [round(p.get_height(), 6) for p in bars] == [0.78, 0.3552, 0.0, 0.0]
    assert [p.get_hatch() for p in bars] == [None, None, "//", "//"]  # binding classes
    assert bars[1].get_linewidth() == 2.0  # the chosen class
    assert any(ln.get_ydata()[0] == 0.6 for ln in a1.get_lines())  # the target
    assert [t.get_text() for t in a1.texts] == ["0.78", "0.3552\nchosen", "binds", "binds"]
    heights = [p.get_height() for p in a2.patches if p.get_width() > 0]
    assert heights == [-8.0, -4.0, 0.0, 4.0]  # round-off below 1e-6 um drawn as exact contact
    assert "0 (exact contact)" in [t.get_text() for t in a2.texts]
    assert "fit roller class +0 um" in fig._suptitle.get_text()
    assert "modified ring" in fig._suptitle.get_text()
    assert is_output_name("assembly.png", ["datasheet"])
