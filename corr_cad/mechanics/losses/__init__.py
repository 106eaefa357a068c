"""The losses: friction, efficiency, hysteresis, drag and heat.

``friction`` Coulomb friction at the roller contacts and in the eccentric
bearing, ``operating`` the running drive at one operating point,
``efficiency`` the efficiency map and rated life, ``hysteresis`` the
hysteresis loss and starting torque, ``lubrication`` the lubricant's
viscosity, ``churning`` and ``bearing_drag`` the losses that do not depend on
the load, ``thermal`` the thermal limit and ``thermal_network`` the
temperature in time.

May import: numpy, scipy, the base modules, :mod:`corr_cad.geometry` and the
ground floor of :mod:`corr_cad.mechanics` (``contact``, ``life``). Never a file
format.
"""
