"""Matplotlib figures of the tolerance studies: ``montecarlo.png``, ``sweep_<name>.png``.

Drawn as :mod:`corr_cad.export.plots` draws (its ``_save`` and ``_title``:
the design line, byte-deterministic files).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.ticker import FuncFormatter, MaxNLocator

from corr_cad.export import plots
from corr_cad.figure_text import figure
from corr_cad.geometry.design import GearDesign
from corr_cad.mechanics.contact import PRESSURE_BOUND_MPA
from corr_cad.tolerance.montecarlo import COUNT_METRICS, metric_percentile

__all__ = ["montecarlo_png", "ranked_montecarlo_png", "sweep_png"]

plt = plots.plt

_LIMIT_OF = {
    "peak_pressure": "max_contact_pressure",
    "peak_gear_force": "max_gear_force",
    "min_loaded_rollers": "min_loaded_rollers",
    "backlash_arcmin": "max_backlash_arcmin",
    "lost_motion_arcmin": "max_lost_motion_arcmin",
    "torsional_rigidity_Nm_per_arcmin": "min_torsional_rigidity_Nm_per_arcmin",
    "transmission_error_arcsec": "max_transmission_error_arcsec",
    "binding_pressure_MPa": None,  # gated by probability: max_binding_probability
}
_LABEL = {
    "peak_gear_force": "peak gear force $F_n$ [N]",
    "peak_pressure": "peak contact pressure [MPa]",
    "min_loaded_rollers": "fewest loaded rollers [-]",
    "backlash_arcmin": "output backlash [arcmin]",
    "lost_motion_arcmin": "lost motion [arcmin]",
    "torsional_rigidity_Nm_per_arcmin": "torsional rigidity [N*m/arcmin]",
    "transmission_error_arcsec": "transmission error, peak to peak [arcsec]",
    "binding_pressure_MPa": "binding preload pressure [MPa]",
}
_SHORT = {
    "peak_pressure": "pressure",
    "peak_gear_force": "$F_n$",
    "min_loaded_rollers": "loaded rollers",
    "backlash_arcmin": "backlash",
    "lost_motion_arcmin": "lost motion",
    "torsional_rigidity_Nm_per_arcmin": "rigidity",
    "transmission_error_arcsec": "transm. error",
    "binding_pressure_MPa": "binding",
}
#: Panel order: the force metrics, then the datasheet metrics and binding when present.
ORDER = tuple(_LABEL)


def _figure_ticks(ax) -> None:
    """x tick labels as catalogue figures: ``13,000``, never an offset or ``1e4``."""
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _pos: figure(v)))


def _bins(values: np.ndarray, integer: bool):
    lo, hi = float(values.min()), float(values.max())
    if integer:
        return np.arange(np.floor(lo) - 0.5, np.ceil(hi) + 1.5)
    return np.histogram_bin_edges(values, bins=min(40, max(10, int(np.sqrt(len(values))))))


def _histogram(ax, name: str, values: np.ndarray, marks: list, pct: dict | None):
    """Histogram with the p5/p50/p95/p99 lines; the x limits when the axis is capped.

    The percentiles are the summary's (``montecarlo_summary.json``, whole
    roller counts for ``min_loaded_rollers``), computed the same way when no
    summary is given. Pressures beyond the Hertz validity bound are not
    spread over the axis: above ``max(1.5 x bound, 1.1 x limit, 1.1 x
    nominal)`` they are counted in one hatched bar, and the bound is drawn.
    """
    count = name in COUNT_METRICS
    bound = PRESSURE_BOUND_MPA if name == "peak_pressure" else None
    cap = None
    if bound is not None and float(values.max()) > 1.5 * bound:
        cap = max([1.5 * bound] + [1.1 * m for m in marks])
        if float(values.max()) <= cap:
            cap = None
    shown = values if cap is None else values[values <= cap]
    lo = min([float(shown.min())] if shown.size else [cap or float(values.min())] + marks)
    lo = min([lo, *marks])
    hi = cap if cap is not None else max([float(values.max()), *marks])
    if cap is not None:
        bins = np.linspace(lo, cap, 31)
    elif not count and np.ptp(values) < 0.05 * (hi - lo):
        # Samples bunched far from the limit: bins over the whole axis, so
        # the bunch is a visible bar, not a one-pixel spike.
        bins = np.linspace(lo, hi, 41)
    else:
        bins = _bins(values, count)
    ax.hist(shown, bins=bins, color="C0", alpha=0.75)
    xlim = None
    if cap is not None:
        w = bins[1] - bins[0]
        over = int(np.count_nonzero(values > cap))
        ax.bar(
            cap + 2 * w,
            over,
            width=3 * w,
            color="C3",
            alpha=0.35,
            hatch="//",
            label=f"{over} samples above {cap:.0f} MPa (off scale)",
        )
        xlim = (lo - 2 * w, cap + 4 * w)
    for q, ls in ((5, ":"), (50, "-"), (95, "--"), (99, "-.")):
        v = float(pct[f"p{q}"]) if pct else metric_percentile(values, q, name)
        off = " (off scale)" if cap is not None and v > cap else ""
        ax.axvline(v, color="0.25", ls=ls, lw=1.0, label=f"p{q} = {figure(v)}{off}")
    if bound is not None and float(values.max()) > bound:
        ax.axvspan(bound, hi * 10, color="0.5", alpha=0.12, lw=0)
        ax.axvline(
            bound,
            color="k",
            ls=(0, (1, 1)),
            lw=1.5,
            zorder=3,
            label=f"{bound:.0f} MPa: end of Hertz validity\n(beyond: read as a fail)",
        )
        if xlim is None:
            lo_x, hi_x = min(lo, bound), max(hi, bound)
            pad = 0.08 * (hi_x - lo_x)
            xlim = (lo_x - pad, hi_x + pad)
    return xlim


def _legend_below(ax) -> None:
    """The panel's legend under its x label: off the bars, the bands and the lines."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        ax.legend(
            handles,
            labels,
            fontsize=7,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.2),
            ncol=3,
            frameon=False,
            handlelength=2.2,
            columnspacing=1.2,
        )


def _layout(fig, panels: int):
    """Histogram axes, the sensitivity axes and the text axes.

    Up to four histograms: two rows of three, the sensitivity top right.
    More (the datasheet metrics and binding): a 3 x 3 block of histograms
    (the text in its last free cell) and the sensitivity down the right.
    """
    if panels <= 4:
        axes = fig.subplots(2, 3).ravel()
        return (
            [axes[i] for i in (0, 1, 3, 4)][:panels],
            axes[2],
            axes[5],
            [axes[i] for i in (0, 1, 3, 4)][panels:],
        )
    gs = fig.add_gridspec(3, 4, width_ratios=(1, 1, 1, 1.15))
    cells = [fig.add_subplot(gs[r, c]) for r in range(3) for c in range(3)]
    sens = fig.add_subplot(gs[:2, 3])  # its legend below, in the column's last cell
    return cells[:panels], sens, cells[panels] if panels < 9 else None, cells[panels + 1 :]


def ranked_montecarlo_png(metrics: dict, *args) -> Path:
    """:func:`montecarlo_png` of every metric the sensitivity ranks (:data:`ORDER`;
    ``binds`` shown as a probability): what the Monte Carlo stage draws."""
    return montecarlo_png({k: v for k, v in metrics.items() if k in ORDER}, *args)


def montecarlo_png(
    metrics: dict,
    checks,
    path: Path,
    summary: dict | None = None,
    nominal: dict | None = None,
    design: GearDesign | None = None,
    input_torque: float | None = None,
    tolerances: dict | None = None,
    binding_pressure_MPa: float | None = None,
) -> Path:
    """Histograms of the per-sample metrics with percentiles, limits and the nominal
    design's value, the failure probability, and the sensitivity ranking.

    Every metric of ``metrics`` gets a panel (the force metrics, and the
    datasheet metrics and the binding preload pressure when the Monte Carlo
    computed them: the sensitivity ranks all of them); ``binds`` (0/1) is
    shown as the binding panel's probability. Whole-number metrics get whole
    ticks; each legend sits below its panel, off the data.
    """
    names = [k for k in ORDER if k in metrics]
    big = len(names) > 4
    fig = plt.figure(figsize=(18, 14) if big else (15, 9.5))
    hist_axes, sens_ax, text_ax, spare = _layout(fig, len(names))
    # The layout first: the legends' room is set against the final axes.
    fig.subplots_adjust(
        left=0.05,
        right=0.98,
        top=0.93 if big else 0.88,
        bottom=0.08 if big else 0.15,
        hspace=0.85 if big else 0.75,
        wspace=0.3,
    )
    n = len(metrics[names[0]])
    binding = (summary or {}).get("binding_probability")
    for ax, name in zip(hist_axes, names, strict=True):
        values = np.asarray(metrics[name], dtype=float)
        lim_key = _LIMIT_OF[name]
        limit = getattr(checks, lim_key) if lim_key else None
        scale = max(abs(float(values.max())), abs(float(values.min())), abs(limit or 0.0), 1.0)
        xlim = None
        if float(values.max() - values.min()) <= 1e-6 * scale:
            # One value for every sample: a histogram would be a one-pixel spike.
            ax.axvline(
                values[0], color="C0", lw=8, alpha=0.6, label=f"all samples: {figure(values[0])}"
            )
            ax.set_ylim(0, n * 1.1)
            ax.text(
                0.5,
                0.55,
                f"all {n} samples: {figure(values[0])}\n(spread below {figure(1e-6 * scale, 1)})",
                transform=ax.transAxes,
                ha="center",
                fontsize=10,
                bbox=dict(facecolor="white", edgecolor="0.7"),
            )
        else:
            marks = [v for v in (limit, (nominal or {}).get(name)) if v is not None]
            pct = ((summary or {}).get("percentiles") or {}).get(name)
            xlim = _histogram(ax, name, values, marks, pct)
        if nominal and name in nominal:
            ax.axvline(
                nominal[name], color="C2", lw=2.0, label=f"nominal = {figure(nominal[name])}"
            )
        if limit is not None:
            ax.axvline(limit, color="C3", lw=2.0, label=f"limit = {figure(limit)}")
            pf = (summary or {}).get("failure_probability", {}).get(lim_key)
            if pf is not None:
                # Red when the gate fails (max_failure_probability), or without a gate when
                # any sample fails; green otherwise.
                allowed = checks.max_failure_probability
                bad = pf > allowed if allowed is not None else pf > 0
                ax.set_title(
                    f"P(fail) = {100 * pf:.1f} %", fontsize=10, color="C3" if bad else "C2"
                )
        elif name == "binding_pressure_MPa":
            if binding_pressure_MPa is not None:
                ax.axvline(
                    binding_pressure_MPa,
                    color="C3",
                    lw=2.0,
                    label=f"binds above {figure(binding_pressure_MPa)} MPa",
                )
            if binding:
                lo, hi = binding["wilson_interval"]
                ax.set_title(
                    f"P(binds) = {figure(100 * binding['probability'], 3)} % "
                    f"(95 %: {figure(100 * lo, 3)} to {figure(100 * hi, 3)} %)",
                    fontsize=10,
                    color="C3" if binding["probability"] > 0 else "C2",
                )
        else:
            ax.set_title("no limit set in [checks]", fontsize=9, color="0.4")
        ax.set_xlabel(_LABEL[name])
        ax.set_ylabel("samples")
        ax.xaxis.set_major_locator(MaxNLocator(6, integer=name in COUNT_METRICS))
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        _figure_ticks(ax)
        ax.margins(x=0.08)
        if xlim is not None:
            ax.set_xlim(*xlim)
        _legend_below(ax)
    for ax in spare:
        ax.axis("off")
    ax = sens_ax
    sens = (summary or {}).get("sensitivity") or []
    if sens:
        kinds = [s["tolerance"] for s in sens]
        ms = [m for m in names if m in sens[0]["spearman"]]
        y = np.arange(len(kinds))
        h = 0.8 / len(ms)
        for j, m in enumerate(ms):
            ax.barh(
                y + (j - (len(ms) - 1) / 2) * h,
                [s["spearman"][m] for s in sens],
                height=h,
                label=_SHORT[m],
                color=f"C{j}",
            )
        ax.set_yticks(y)
        ax.set_yticklabels([k.replace("_", " ") for k in kinds], fontsize=8)
        ax.invert_yaxis()
        ax.axvline(0, color="k", lw=0.6)
        ax.set_xlim(-1, 1)
        ax.set_xlabel("Spearman rank correlation with |drawn error| [-]")
        ax.legend(
            fontsize=8 if big else 7,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.12 if big else -0.2),
            ncol=2 if big else 4,
            frameon=False,
        )
    ax.set_title("sensitivity (most influential first)", fontsize=10)
    lines = ["Tolerances (centred on the [errors] values):"]
    for k, d in (tolerances or {}).items():
        kind, scale = (d.kind, d.scale) if hasattr(d, "kind") else (d["kind"], d["scale"])
        what = "sigma" if kind == "normal" else "uniform +-"
        unit = "deg" if k in ("cam_phase", "slot_angle") else "mm"
        lines.append(f"  {k.replace('_', ' ')}: {what} {figure(scale)} {unit}")
    lines.append("")
    lines.append("Lines: p5 dotted, p50 solid,")
    lines.append("p95 dashed, p99 dash-dot;")
    lines.append("green = nominal design,")
    lines.append("red = limit from [checks].")
    if text_ax is not None:
        text_ax.axis("off")
        text_ax.text(0.0, 1.0, "\n".join(lines), va="top", fontsize=9, family="monospace")
    plots._title(fig, f"Monte Carlo over the tolerances, {n} samples", design, input_torque)
    return plots._save(fig, path)


def sweep_png(
    name: str,
    points: list[dict],
    path: Path,
    rng: dict | None = None,
    design: GearDesign | None = None,
    input_torque: float | None = None,
    design_value: float | None = None,
) -> Path:
    """Means and peaks of roller 1's forces against the swept value (Figs. 11-16 style).

    The design's own value is marked (dashed red, in the legend):
    ``design_value``, by default the design parameter of that name, or 0 (no
    error) for an error sweep. The legends sit above the panels, off the data.
    """
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 5.6))
    ok = [p for p in points if p["status"] == "ok"]
    x = [p["value"] for p in ok]
    for key, label in (("F_j_mean", "$F_j$"), ("F_n_mean", "$F_n$"), ("F_s_mean", "$F_s$")):
        ax1.plot(x, [p[key] for p in ok], "o-", label=f"mean {label}")
    for key, label in (
        ("F_j_peak", "peak $F_j$"),
        ("F_n_peak", "peak $F_n$"),
        ("F_s_peak_to_peak", "p-p $F_s$"),
    ):
        ax2.plot(x, [p[key] for p in ok], "o-", label=label)
    skipped = [p["value"] for p in points if p["status"] != "ok"]
    label = name.replace("_", " ")
    is_error = name.endswith("_error")
    if design_value is None and design is not None:
        design_value = 0.0 if is_error else getattr(design, name, None)
    if design_value is not None:
        if not is_error:
            mark = f"design {label} {design_value:g} mm"
        elif design_value == 0:
            mark = "design (no error)"
        else:
            mark = f"design: the scene's {label} {design_value:g} mm"
        for ax in (ax1, ax2):
            ax.axvline(design_value, color="C3", lw=0.9, ls="--", label=mark)
    for ax in (ax1, ax2):
        for v in skipped:
            ax.axvline(v, color="0.7", ls=":", lw=1)
        ax.set_xlabel(label + " [mm]")
        ax.set_ylabel("force on roller 1 [N]")
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.grid(alpha=0.3)
        if ok or design_value is not None:
            ax.legend(
                fontsize=8,
                ncol=2,
                loc="lower left",
                bbox_to_anchor=(0.0, 1.02, 1.0, 0.0),
                mode="expand",
                borderaxespad=0.0,
            )
    notes = []
    if rng is not None:
        src = {"scene": "[sweeps] range", "paper": "the paper's range", "default": "default range"}
        notes.append(
            f"{src.get(rng['source'], rng['source'])} {rng['requested'][0]:g} .. "
            f"{rng['requested'][1]:g} mm"
        )
        if rng["swept"] is None:
            notes.append("no valid value in the range")
        else:
            for side, i in (("low", 0), ("high", 1)):
                why = rng[f"clipped_{side}"]
                if why:
                    notes.append(f"{side} end clipped at {rng['swept'][i]:.5g} mm ({why})")
    if skipped:
        notes.append(f"dotted: {len(skipped)} points not computed - undercut or invalid")
    if not ok:
        for ax in (ax1, ax2):
            ax.text(0.5, 0.5, "no valid point", transform=ax.transAxes, ha="center")
    fig.text(0.5, 0.01, "; ".join(notes), ha="center", fontsize=8)
    plots._title(fig, f"Sweep of the {label}", design, input_torque)
    fig.subplots_adjust(left=0.07, right=0.98, top=0.78, bottom=0.15, wspace=0.25)
    return plots._save(fig, path)
