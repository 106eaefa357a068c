"""Mechanics: contact, and the mesh-force solver of the paper's Section 3.

Holds the Hertz line-contact law (``contact``), the solver (``solver``, with
its roller geometry, numerics and the fast path for a design without errors),
the output windup under output torque with the crank locked (``windup``) and
the datasheet figures read off it (``datasheet``), the compiled Monte Carlo
kernel (``mc_kernel``) and the slow, independent reference solver
(``reference``).

May import: numpy, scipy, numba (``mc_kernel`` only), the base modules and
:mod:`corr_cad.geometry`. Never a file format.
"""
