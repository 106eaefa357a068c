"""corr_cad: profiles, machining files and mesh forces for compound oscillatory roller reducers.

Units everywhere: millimetres, newtons, radians, megapascals (N/mm^2);
torque in N*mm. Degrees appear only at the edges (scene files, CSV, plots).
Angles are measured from +y towards +x, as in Wei et al., Chin. J. Mech.
Eng. 34:84 (2021).
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
]
