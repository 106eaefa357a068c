"""Geometry: the drive's design and every curve and outline derived from it.

Holds the design parameters (:mod:`~corr_cad.geometry.design`), the
kinematics of the roller centres, the exact conjugate profile and its
undercut test, projection onto it, the approximation of a profile by arcs,
lines or splines with its measured deviation (``sampling``, ``biarcs``,
``measure``), part outlines, assembly placement, the exact clearance of
every roller, and the error model (``deviations``), which the clearance and
the force solver both take as input.

May import: numpy, scipy, shapely, :mod:`corr_cad.errors` and
:mod:`corr_cad.bounds`. Never a file format, and nothing above this layer.
"""
