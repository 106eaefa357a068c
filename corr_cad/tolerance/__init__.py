"""Tolerance: what the errors do to the drive, and what a made part measures.

Holds the design checks, the seeded Monte Carlo and the tolerance allocation
(``montecarlo``), parameter sweeps (``sweeps``), registration of a measured
gear profile (``measured``) and the per-tooth inspection of a made ring
(``inspection``).

May import: numpy, scipy, the base modules, :mod:`corr_cad.geometry` and
:mod:`corr_cad.mechanics`. Never a file format.
"""
