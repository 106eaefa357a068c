"""One exception tree for corr_cad.

Every error a user can cause derives from :class:`CorrCadError` and from the
matching built-in, so ``except ValueError`` keeps working for callers that do
not know this package.
"""

from __future__ import annotations

__all__ = [
    "CorrCadError",
    "DesignError",
    "ProfileError",
    "UndercutError",
    "SolverError",
    "SceneError",
    "ExportError",
    "OutputError",
]


class CorrCadError(Exception):
    """Base class of all corr_cad errors."""


class DesignError(CorrCadError, ValueError):
    """A design parameter is out of its allowed range."""


class ProfileError(CorrCadError, ValueError):
    """The tooth profile cannot be built as requested."""


class UndercutError(ProfileError):
    """The working profile self-intersects (pointed or undercut tooth)."""


class SolverError(CorrCadError, ArithmeticError):
    """The force solver got inputs it cannot solve."""


class SceneError(CorrCadError, ValueError):
    """A scene file is malformed or names unknown keys."""


class ExportError(CorrCadError, RuntimeError):
    """An exporter could not write or verify a file."""


class OutputError(CorrCadError, OSError):
    """The output folder cannot be used, or a file in it is not corr-cad's to replace."""
