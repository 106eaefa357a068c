"""The estimate of what the drive runs: a datasheet pulled in by a check."""

from __future__ import annotations

import pytest


def test_a_datasheet_pulled_in_by_min_efficiency_is_costed_with_its_friction_figures():
    """A drive datasheet that only ``[checks] min_efficiency`` asks for was estimated at its
    windup alone (0.46 s; the friction figures took 1.6 s of CPU): the friction's positions
    (the datasheet's span at ``[friction] positions_per_mesh``) at the drive's cell cost."""
    from corr_cad.run.budget.costs_friction import FRICTION_CELL_SECONDS
    from corr_cad.run.budget.resources import estimate
    from corr_cad.run.scene.scene import parse_scene

    base = {
        "export": {"formats": ["forces"]},
        "load": {"input_torque": 1.1e5},
        "solver": {"model": "drive", "contact_law": "palmgren"},
    }
    plain = estimate(parse_scene(base), 2, "process")
    checked = estimate(parse_scene({**base, "checks": {"min_efficiency": 0.5}}), 2, "process")
    sheet = {**base, "export": {"formats": ["forces", "datasheet"]}}
    windup = estimate(parse_scene(sheet), 2, "process").stages["datasheet"].seconds
    assert "datasheet" not in plain.stages
    # 4 friction positions (a mesh period of the nominal drive) x 26 rollers x 10 (the drive)
    # at 1.5 ms: 1.56 s, what the figures took (1.6 s of CPU)
    assert checked.stages["datasheet"].seconds - windup == pytest.approx(1.56, rel=1e-9)
    assert FRICTION_CELL_SECONDS == 1.5e-3
