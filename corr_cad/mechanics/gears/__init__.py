"""The first stage: the spur gear pair ahead of the reducer.

``first_stage_loads`` its loads and ratings, ``first_stage_mesh`` its mesh.

May import: numpy, scipy, the base modules and :mod:`corr_cad.geometry`. Never a
file format.
"""
