"""efficiency.png reads as a catalogue figure: torques with thousands separators,
efficiencies in plain percent (no offset, no scientific notation) and a title that
fits inside the figure."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from corr_cad.export.friction_io import efficiency_figure  # noqa: E402
from corr_cad.mechanics.losses.efficiency import FrictionFigures  # noqa: E402
from corr_cad.mechanics.losses.friction import Friction  # noqa: E402


def _figures(forward: float) -> FrictionFigures:
    shares = np.linspace(0.1, 1.0, 10)
    s = len(shares)
    return FrictionFigures(
        rated_torque=2.6e7,  # N*mm: a 26,000 N*m drive
        shares=shares,
        speeds_rpm=np.array([500.0, 1000.0, 2000.0]),
        # A Coulomb map is flat; forward and backdriving nearly equal (light friction).
        forward=np.full(s, forward) + 1e-7 * np.arange(s),
        backdriving=np.full(s, forward - 1e-6),
        losses_forward=np.zeros((s, 4)),
        losses_backdriving=np.zeros((s, 4)),
        input_power=np.ones(s),
        output_power=np.ones(s),
        balance=0.0,
        friction=Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 82.4),
        ratio=-26.0,
    )


def test_efficiency_png_ticks_are_plain_and_the_title_fits():
    fig = efficiency_figure(_figures(0.8748))
    try:
        fig.canvas.draw()
        ax = fig.axes[0]
        xt = [t.get_text() for t in ax.get_xticklabels() if t.get_text()]
        # 26,000 N*m of output torque: every tick of 1,000 and more has its separator.
        big = [t for t in xt if float(t.replace(",", "")) >= 1000]
        assert big and all("," in t for t in big), xt
        yt = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
        assert yt and not any("e" in t.lower() for t in yt), yt
        assert ax.yaxis.get_offset_text().get_text() == ""
        assert ax.xaxis.get_offset_text().get_text() == ""
        r = fig.canvas.get_renderer()
        title = ax.title.get_window_extent(r)
        width = fig.bbox.width
        assert title.x0 >= 0 and title.x1 <= width, (title, width)
    finally:
        plt.close(fig)
