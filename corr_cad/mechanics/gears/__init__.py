"""The first stage: the gear pair that drives the crank, in the whole drive.

``first_stage_loads`` the whole drive's ratio, mass and inertia and the first
stage's loads and stresses; ``first_stage_mesh`` its meshes: sliding loss,
mesh stiffness, play at the output.

May import: numpy, scipy, the base modules and :mod:`corr_cad.geometry`. Never a
file format.
"""
