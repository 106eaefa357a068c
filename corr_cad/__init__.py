"""corr_cad: profiles, machining files and mesh forces for compound oscillatory roller reducers.

Units everywhere: millimetres, newtons, radians, megapascals (N/mm^2);
torque in N*mm. Degrees appear only at the edges (scene files, CSV, plots).
Angles are measured from +y towards +x, as in Wei et al., Chin. J. Mech.
Eng. 34:84 (2021).

The API in one breath (``docs/api.md`` walks through it)::

    >>> import corr_cad as cc
    >>> d = cc.GearDesign(tooth_count=25, cam_radius=135.0, roller_radius=8.0, eccentricity=3.5)
    >>> round(cc.admissible_roller_radius(d), 3)     # undercut limit, mm
    10.053
    >>> prof = cc.working_profile(d)
    >>> cc.approximate(prof, "arcs", 1e-3).max_deviation < 1e-3
    True
    >>> res = cc.solve_forces(d, 1.1e5, positions=360)
    >>> round(res.summary()["F_j_mean"])             # N, roller 1
    1742

The force solver, Monte Carlo, allocation and the scene runner are loaded on
first use, so ``import corr_cad`` and a DXF-only run stay quick.
"""

from __future__ import annotations

# First, before numpy and scipy load: Ctrl-C while the command starts is one line.
from corr_cad import _startup  # noqa: F401  (isort: skip)
from corr_cad._version import __version__
from corr_cad.errors import (
    CorrCadError,
    DesignError,
    ExportError,
    ProfileError,
    SceneError,
    SolverError,
    UndercutError,
)
from corr_cad.geometry.design import GearDesign, Material
from corr_cad.geometry.profile import (
    ProfileCurve,
    UndercutInfo,
    admissible_roller_radius,
    theoretical_profile,
    undercut_analysis,
    working_profile,
)
from corr_cad.geometry.sampling import ProfileApproximation, approximate

#: Public names loaded on first access: name -> module.
_LAZY = {
    "load_scene": "run.scene.scene",
    "parse_scene": "run.scene.scene",
    "Scene": "run.scene.scene",
    "run_scene": "run.pipeline",
    "solve_forces": "mechanics.row.solver",
    "ForceResult": "mechanics.row.solver",
    "Windup": "mechanics.row.windup",
    "DatasheetSpec": "mechanics.datasheet",
    "datasheet": "mechanics.datasheet",
    "ManufacturingErrors": "geometry.deviations",
    "monte_carlo": "tolerance.montecarlo",
    "allocate": "tolerance.allocation",
    "Distribution": "tolerance.montecarlo",
    "Checks": "tolerance.checks",
    "MonteCarloResult": "tolerance.montecarlo",
    "scene_json_schema": "run.scene.schema_json",
}

__all__ = [
    "__version__",
    "GearDesign",
    "Material",
    "CorrCadError",
    "DesignError",
    "ExportError",
    "ProfileError",
    "SceneError",
    "SolverError",
    "UndercutError",
    "ProfileCurve",
    "UndercutInfo",
    "admissible_roller_radius",
    "theoretical_profile",
    "undercut_analysis",
    "working_profile",
    "ProfileApproximation",
    "approximate",
    *_LAZY,
]


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'corr_cad' has no attribute {name!r}")
    from importlib import import_module

    value = getattr(import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
