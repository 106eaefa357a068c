"""The elastic bodies: the gear ring and the slotted frame by finite elements.

``mesh`` triangulates a region bounded by the exported part outlines
(numpy, scipy, shapely); ``plane`` is the plane-stress finite-element body
(scikit-fem: the one module of the numerical core that imports it);
``reduction`` reduces the ring and a frame plate to influence tables once per
design; ``coupling`` turns the tables into each crank position's influence
matrix between the rollers' overlaps, which the drive's solve adds to the
contacts' compliance.

May import: numpy, scipy, shapely, skfem (``plane`` only), the base modules,
:mod:`corr_cad.geometry` and the rest of :mod:`corr_cad.mechanics`. Never a
file format.
"""
