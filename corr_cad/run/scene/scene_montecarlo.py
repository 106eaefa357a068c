"""Scene checks of the Monte Carlo's gates that concern the datasheet metrics and binding.

Called from :func:`corr_cad.run.scene.scene.parse_scene` (one line there).
"""

from __future__ import annotations

from corr_cad.errors import SceneError
from corr_cad.tolerance.checks import Checks

__all__ = ["check_binding_gate", "wants_datasheet_metrics"]


def check_binding_gate(checks: Checks, formats: tuple) -> None:
    """``[checks] max_binding_probability`` in [0, 1], and only with a Monte Carlo."""
    p = checks.max_binding_probability
    if p is None:
        return
    if p < 0:
        raise SceneError(
            f"[checks] max_binding_probability = {p:g}: allowed range is [0, 1], e.g. 0.01"
        )
    if "montecarlo" not in formats and "allocation" not in formats:
        raise SceneError(
            "[checks] max_binding_probability gates the Monte Carlo: "
            "add 'montecarlo' to [export] formats"
        )


def wants_datasheet_metrics(scene) -> bool:
    """Whether the Monte Carlo and allocation compute the datasheet metrics and binding.

    When the scene asks for the datasheet (the format, a ``[datasheet]``
    section, a check on a datasheet figure) or gates binding.
    """
    return (
        "datasheet" in scene.formats
        or "datasheet" in scene.source
        or bool(scene.checks.datasheet_active())
        or scene.checks.max_binding_probability is not None
    )
