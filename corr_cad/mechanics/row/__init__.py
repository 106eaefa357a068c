"""The paper's row: one row of rollers on a rigid cam (Section 3, corrected).

``solver`` solves the mesh forces (with its roller geometry ``solver_geometry``,
numerics ``solver_numerics`` and the fast path without errors ``solver_nominal``);
``batch`` many error sets at once; ``windup`` the output windup under output
torque with the crank locked; ``mc_kernel`` and ``mc_windup_kernel`` the
compiled Monte Carlo kernels (numba).

May import: numpy, scipy, numba (the kernels), the base modules,
:mod:`corr_cad.geometry` and the ground floor of :mod:`corr_cad.mechanics`
(``contact``, ``palmgren``). Never a file format.
"""
