"""The crankshaft and its bearings: the shaft line's compliances under the drive.

``crankshaft`` is the Timoshenko shaft between its support bearings,
``support_bearing`` the support bearings' stiffness, load and life, ``bearing``
the needle bearing a cam floats on.

May import: numpy, scipy, the base modules and the ground floor of
:mod:`corr_cad.mechanics` (``contact``, ``palmgren``, ``life``). Never a file
format.
"""
