"""The losses: friction, efficiency, hysteresis, drag and heat.

``friction`` and ``operating`` the contacts' friction at an operating point,
``efficiency`` the efficiency map, ``hysteresis`` the loaded loop,
``lubrication``, ``churning`` and ``bearing_drag`` the lubricant's share,
``thermal`` and ``thermal_network`` the temperature.

May import: numpy, scipy, the base modules, :mod:`corr_cad.geometry` and the
ground floor of :mod:`corr_cad.mechanics` (``contact``, ``life``). Never a file
format.
"""
