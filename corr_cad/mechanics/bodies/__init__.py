"""The elastic bodies: the gear ring, the slotted frame and the cams by finite elements.

``mesh`` triangulates a region bounded by the exported part outlines
(numpy, scipy, shapely); ``plane`` is the plane-stress finite-element body
(scikit-fem: the one module of the numerical core that imports it);
``reduction`` reduces the ring, a frame plate and a cam to influence tables
once per design (:class:`~corr_cad.mechanics.drive.coupling.BodyTables`), which
the drive's solve turns into each crank position's influence matrix
(:mod:`corr_cad.mechanics.drive.coupling`).

May import: numpy, scipy, shapely, skfem (``plane`` only), the base modules,
:mod:`corr_cad.geometry` and the rooms of :mod:`corr_cad.mechanics` below it (the
drive's coupling among them). Never a file format.
"""
