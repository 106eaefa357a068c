"""The datasheet's files: ``datasheet.json``, ``windup.csv``, ``transmission_error.csv``.

Every figure in ``datasheet.json`` can be recomputed by hand from the two
CSV files (``docs/datasheet.md`` shows how):

* ``windup.csv``: ``output_torque_Nm, output_angle_deg, windup_arcmin``, one
  curve per position (position-major), torque ascending from ``-T_R`` to
  ``+T_R``. Zero torque has two rows, ``-0`` (the end of the free rotation
  reached from negative torque, ``theta(0-)``) then ``0`` (``theta(0+)``).
  The levels of the lost-motion band, the rigidity range and the K
  breakpoints are rows of it. Under ``[solver] model = "drive"`` a fourth
  column ``row_a_share`` gives row A's share of the moment at that level.
* ``transmission_error.csv``: ``output_angle_deg, forward_arcsec,
  reverse_arcsec`` over one output revolution.

Angles in the files: output angle in degrees, windup in arcmin, transmission
error in arcsec; torque in N*m.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from corr_cad.export.files import write_columns, write_json
from corr_cad.mechanics.datasheet import Datasheet
from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD, ARCSEC_PER_RAD, NMM_PER_NM

__all__ = ["WINDUP_COLUMNS", "TE_COLUMNS", "write_datasheet_files"]

#: windup.csv columns (an interface: the names do not change).
WINDUP_COLUMNS = ("output_torque_Nm", "output_angle_deg", "windup_arcmin")
#: transmission_error.csv columns.
TE_COLUMNS = ("output_angle_deg", "forward_arcsec", "reverse_arcsec")


def write_datasheet_files(ds: Datasheet, out: Path, meta: dict | None = None) -> list[str]:
    """Write the three data files into ``out``; returns their names.

    ``meta``: what else ``datasheet.json`` records (design, load share,
    contact model, conventions), merged in at the top level.
    """
    out = Path(out)
    L, P = ds.windup.shape
    columns = [
        np.tile(ds.torques / NMM_PER_NM, P),
        np.repeat(np.degrees(ds.output_angles), L),
        (ds.windup.T * ARCMIN_PER_RAD).ravel(),
    ]
    names, fmts = WINDUP_COLUMNS, ("%.9g", "%.12g", "%.12g")
    if ds.row_a_share is not None:  # the drive model: row A's share at each level
        columns.append(ds.row_a_share.T.ravel())
        names, fmts = (*names, "row_a_share"), (*fmts, "%.12g")
    write_columns(out / "windup.csv", names, columns, fmts)
    write_columns(
        out / "transmission_error.csv",
        TE_COLUMNS,
        [
            np.degrees(ds.te_output_angles),
            ds.te_forward * ARCSEC_PER_RAD,
            ds.te_reverse * ARCSEC_PER_RAD,
        ],
        ("%.12g", "%.12g", "%.12g"),
    )
    write_json(out / "datasheet.json", {**(meta or {}), **ds.figures()})
    return ["datasheet.json", "windup.csv", "transmission_error.csv"]
