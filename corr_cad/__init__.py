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

__version__ = "0.1.0"

from .design import GearDesign, Material
from .errors import (
    CorrCadError,
    DesignError,
    ExportError,
    ProfileError,
    SceneError,
    SolverError,
    UndercutError,
)
from .profile import (
    ProfileCurve,
    UndercutInfo,
    admissible_roller_radius,
    theoretical_profile,
    undercut_analysis,
    working_profile,
)
from .sampling import ProfileApproximation, approximate

#: Public names loaded on first access: name -> module.
_LAZY = {
    "load_scene": "scene",
    "parse_scene": "scene",
    "Scene": "scene",
    "run_scene": "pipeline",
    "solve_forces": "solver",
    "ForceResult": "solver",
    "ManufacturingErrors": "deviations",
    "monte_carlo": "tolerance",
    "allocate": "tolerance",
    "Distribution": "tolerance",
    "Checks": "tolerance",
    "MonteCarloResult": "tolerance",
    "scene_json_schema": "schema_json",
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
