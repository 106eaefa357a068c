"""The drive: both rows, the cams floating on their bearings, one solve.

``drive`` is the drive's solver (``DriveSolver``, ``solve_drive``), with its
numerics ``drive_numerics``, restarts ``drive_restart``, the crankshaft in the
solve ``drive_crank``, the windup ``drive_windup``; ``drive_kernel``,
``drive_laws``, ``drive_centre`` and ``free_play`` the compiled kernels (numba);
``coupling`` and ``coupling_kernel`` the elastic bodies' influence in the solve.

May import: numpy, scipy, numba (the kernels), the base modules,
:mod:`corr_cad.geometry`, the ground floor of :mod:`corr_cad.mechanics`,
:mod:`corr_cad.mechanics.row` and :mod:`corr_cad.mechanics.crank`. Never a file
format.
"""
