"""Shop: what the machine shop runs, as numbers (the files are written by export).

Holds the wire-EDM cut (``edm``): the tooth opening offset by wire radius
and spark gap, lead-in and lead-out, and the deviation of the path.

May import: numpy, scipy, the base modules and :mod:`corr_cad.geometry`.
Never a file format.
"""
