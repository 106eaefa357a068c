"""Export: the only modules that import ezdxf, trimesh, manifold3d, OCP, matplotlib or jinja2.

Holds one module per file format (``dxf``, ``mesh``, ``step``, ``plots``,
``report``, ``edm_io``, ``inspection_io``, ``measured_io``), the text writers
every stage uses (``files``: atomic JSON and CSV, sha256, file-name tags) and
the guarded reader of user input files (``inputfiles``).

May import: the base modules, :mod:`corr_cad.geometry`,
:mod:`corr_cad.mechanics`, :mod:`corr_cad.tolerance` and :mod:`corr_cad.shop`.
Never :mod:`corr_cad.run`.
"""
