"""Mechanics: the contact laws, the paper's row, the drive, the bodies, the losses.

Cut by concept into rooms, one way up (``tests/test_layout.py``):

- the ground floor: the Hertz line-contact law (``contact``), Palmgren's
  (``palmgren``), the rolling bearings' ratings (``life``, ``life_modified``)
  and the slow, independent reference solver (``reference``);
- ``row``: the paper's row, its solver, windup and compiled Monte Carlo
  kernels; ``crank``: the crankshaft, its support bearings and the needle
  bearing a cam floats on; ``losses``: friction, efficiency, hysteresis, drag
  and heat; ``gears``: the first stage;
- ``drive``: both rows on floating cams in one solve, with the crankshaft and
  the elastic bodies' influence; ``binding``: whether the drive assembles at zero torque;
- ``bodies``: the ring, frame and cams by finite elements, reduced to the
  drive's influence tables; ``compliance_budget``: the windup split by
  component;
- ``datasheet``: the figures read off a solved row or drive.

May import: numpy, scipy, numba (the compiled kernels), shapely, scikit-fem
(``bodies/plane.py`` only), the base modules and :mod:`corr_cad.geometry`.
Never a file format.
"""
