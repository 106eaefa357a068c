"""Scene sections on what a drive does under tolerances: ``[datasheet]``,
``[tolerances]``, ``[montecarlo]`` and ``[sweeps]`` (part of
:data:`corr_cad.run.scene.scene_schema.SCHEMA`)."""

from __future__ import annotations

from corr_cad.mechanics.datasheet import MIN_RATED_TORQUE_NMM, MIN_SHARE
from corr_cad.run.scene.scene_key import Key
from corr_cad.tolerance.montecarlo import TOLERANCE_KINDS
from corr_cad.tolerance.sweeps import PAPER_SWEEPS

#: Ranges of the tolerance scales that depend on the design (like the errors).
_TOL_NOTE = {
    "cam_radius": "[0, r/2)",
    "eccentricity": "[0, r/2)",
    "roller_radius": "[0, r/2)",
    "slot_angle": "[0, 90/(z+1)) deg",
    "cam_phase": "[0, 180] deg",
    "slot_clearance": '[0, 1] (model = "drive")',
}

SECTIONS: dict[str, dict[str, Key]] = {
    "datasheet": {
        "rated_torque_Nm": Key(
            "float",
            None,
            "T_R, rated output torque the figures refer to, N*m "
            "(default: (z + 1) * [load] input_torque)",
            low=MIN_RATED_TORQUE_NMM / 1000,
            low_open=False,
            high=1e9,
            example=2860.0,
        ),
        "lost_motion_band": Key(
            "float",
            0.03,
            "lost motion at +- this share of T_R (RV catalogues 0.03, strain-wave 0.04)",
            low=MIN_SHARE,
            low_open=False,
            high=1,
            high_open=True,
        ),
        "rigidity_range": Key(
            "list[float]",
            [0.5, 1.0],
            "[T_1, T_2] of the torsional rigidity, shares of T_R",
            low=0,
            low_open=False,
            high=1,
            max_len=2,
            note=f"two values, T_2 - T_1 >= {MIN_SHARE:g}",
        ),
        "transmission_error_torque_band": Key(
            "float",
            0.03,
            "driving torque of the transmission error, share of T_R",
            low=MIN_SHARE,
            low_open=False,
            high=1,
            high_open=True,
        ),
        "positions_per_mesh": Key(
            "int",
            16,
            "output positions per mesh period of the windup curve",
            low=0,
            high=10000,
            note="and within the memory budget ([budget] memory_gb, default 3 GB)",
        ),
        "transmission_error_positions_per_turn": Key(
            "int",
            360,
            "positions per crank (input) turn of the transmission error",
            low=0,
            high=100000,
            note="and within the memory budget ([budget] memory_gb, default 3 GB)",
        ),
        "allowable_contact_pressure_MPa": Key(
            "float",
            None,
            "rate the torque from contact pressure: allowable peak Hertz pressure, MPa",
            low=0,
            high=1e6,
            example=1500.0,
        ),
        "series_rigidity_Nm_per_arcmin": Key(
            "float",
            None,
            "rigidity in series with the contacts (bearings, crank, frame, housing), "
            "N*m/arcmin (default: none)",
            low=0,
            high=1e9,
            example=1000.0,
        ),
    },
    "tolerances": {
        kind: Key(
            "distribution",
            None,
            f"{kind.replace('_', ' ')} tolerance, {unit}: "
            "{ normal = sigma } or { uniform = half width }",
            example={"normal": 0.001 if unit == "mm" else 0.01},
            note=_TOL_NOTE[kind],
        )
        for kind, (_, unit) in TOLERANCE_KINDS.items()
    },
    "montecarlo": {
        "samples": Key(
            "int",
            1000,
            "Monte Carlo samples",
            low=0,
            high=10_000_000,
            note="and within the memory budget ([budget] memory_gb, default 3 GB)",
        ),
        "seed": Key("int", 1, "random seed (runs are reproducible)", low=-1, high=1e9),
        "positions": Key(
            "int",
            360,
            "crank positions per sample (full cycle)",
            low=0,
            high=100_000,
            note="and within the memory budget ([budget] memory_gb, default 3 GB)",
        ),
        "percentile": Key(
            "float", 95.0, "percentile the allocation keeps under the limits", low=0, high=100
        ),
        "allocation_samples": Key(
            "int", 200, "samples per step of the allocation search", low=0, high=100_000
        ),
        "datasheet_positions_per_mesh": Key(
            "int",
            4,
            "positions per mesh period of each sample's datasheet metrics (one mesh period, "
            "one tooth pitch or one output revolution, as the errors need)",
            low=0,
            high=1000,
        ),
        "binding_pressure_MPa": Key(
            "float",
            4000.0,
            "a sample binds when its gap-only preload pressure at zero torque exceeds this, MPa "
            "(default: 4000, the static capacity of bearing steel in line contact, ISO 76)",
            low=0,
            high=1e6,
        ),
    },
    "sweeps": {
        "points": Key("int", 7, "points per sweep", low=1, high=1000),
        "positions": Key("int", 720, "crank positions per sweep point", low=0, high=100_000),
        **{
            name: Key(
                "list[float]",
                None,
                f"[min, max] of the {name.replace('_', ' ')} sweep, mm (default: "
                + (
                    "+-20 % of the design value"
                    if where == "design"
                    else "+-0.02 mm around the [errors] value"
                )
                + "; the paper's range for its Table 1 design; clipped to the valid design space)",
                example=[lo, hi],
                max_len=2,
            )
            for name, (where, lo, hi) in PAPER_SWEEPS.items()
        },
    },
}
