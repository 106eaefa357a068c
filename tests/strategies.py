"""Hypothesis strategies for valid designs, kept inside the undercut limit."""

from __future__ import annotations

import math

from hypothesis import assume
from hypothesis import strategies as st

from corr_cad import DesignError, GearDesign, admissible_roller_radius


@st.composite
def designs(draw, max_teeth: int = 60, undercut_share: float = 0.97) -> GearDesign:
    z = draw(st.integers(3, max_teeth))
    cam_radius = draw(st.floats(20.0, 300.0))
    e = draw(st.floats(0.2, 0.08 * cam_radius))
    r_adm = admissible_roller_radius(z, e, cam_radius)
    share = draw(st.floats(0.1, undercut_share))
    r = share * min(r_adm, 0.3 * cam_radius) if math.isfinite(r_adm) else share * 0.3 * cam_radius
    try:
        return GearDesign(tooth_count=z, cam_radius=cam_radius, roller_radius=r, eccentricity=e)
    except DesignError:
        assume(False)
