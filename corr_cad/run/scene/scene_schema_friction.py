"""Scene sections of friction and fatigue: ``[friction]`` and ``[life]`` (part of
:data:`corr_cad.run.scene.scene_schema.SCHEMA`). Either one makes the ``datasheet``
format compute the efficiency map, the hysteresis with friction and the rated life."""

from __future__ import annotations

from corr_cad.errors import SceneError
from corr_cad.mechanics.losses.friction import MOUNTINGS
from corr_cad.run.scene.scene_key import Key, key_range
from corr_cad.run.scene.scene_schema_drive import MIN_NEEDLE_MM

#: Efficiency map defaults: output torques as shares of T_R, input speeds.
EFFICIENCY_TORQUES = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]
EFFICIENCY_SPEEDS_RPM = [500.0, 1000.0, 2000.0]


def _mu(what: str, default: float, typical: str) -> Key:
    return Key(
        "float",
        default,
        f"Coulomb coefficient of {what} ({typical})",
        low=0,
        high=1,
        low_open=False,
    )


SECTIONS: dict[str, dict[str, Key]] = {
    "friction": {
        "mu_cam": _mu("the cam-roller contact", 0.05, "lubricated hardened steel 0.05-0.1"),
        "mu_slot": _mu("the roller-slot contact", 0.05, "lubricated hardened steel 0.05-0.1"),
        "mu_ring": _mu("the roller-ring contact", 0.05, "lubricated hardened steel 0.05-0.1"),
        "mu_bearing": _mu(
            "the eccentric needle bearing, M = 0.5 mu P d",
            0.0025,
            "SKF/Koyo: needle roller and cage 0.002-0.003",
        ),
        "mu_mesh": _mu(
            "the first stage's tooth meshes, mean over the path of contact (with "
            "[first_stage]; ISO/TR 14179-2's mu_mz)",
            0.05,
            "lubricated steel gears 0.04-0.08",
        ),
        "cam_mounting": Key(
            "str",
            "bearing",
            "the cam floats on its needle bearing, or is one body with the crank",
            choices=MOUNTINGS,
        ),
        "bearing_bore_mm": Key(
            "float",
            None,
            "d of M = 0.5 mu P d, mm (default: the cam bore less two needle diameters)",
            low=0,
            high=1e5,
            example=82.4,
        ),
        "positions_per_mesh": Key(
            "int",
            4,
            "output positions per mesh period of the efficiency, hysteresis and life "
            "(over the datasheet's span)",
            low=0,
            high=1000,
        ),
        "housing_area_m2": Key(
            "float",
            None,
            "thermal limit: the housing's outer surface, m^2 (default: no thermal limit)",
            low=0,
            high=1e4,
            example=0.25,
        ),
        "heat_transfer_W_per_m2K": Key(
            "float",
            18.0,
            "thermal limit: heat transfer coefficient of the housing, W/(m^2 K) (still air 15-20)",
            low=0,
            high=1e4,
        ),
        "max_temperature_rise_K": Key(
            "float",
            40.0,
            "thermal limit: allowed rise of the housing surface over the ambient, K",
            low=0,
            high=1000,
        ),
        "efficiency_torques": Key(
            "list[float]",
            EFFICIENCY_TORQUES,
            "output torques of the efficiency map, shares of T_R",
            low=0,
            high=1,
            max_len=100,
        ),
        "efficiency_speeds_rpm": Key(
            "list[float]",
            EFFICIENCY_SPEEDS_RPM,
            "input speeds of the efficiency map, rpm",
            low=0,
            high=1e6,
            max_len=20,
        ),
    },
    "life": {
        "rated_life_h": Key(
            "float",
            6000.0,
            "L10 at the rated torque from life, h (RV catalogues 6000)",
            low=0,
            high=1e9,
        ),
        "rated_speed_rpm": Key(
            "float",
            15.0,
            "output speed of the rated life, rpm (RV catalogues 15)",
            low=0,
            high=1e6,
        ),
        "dynamic_load_rating_N": Key(
            "float",
            None,
            "C_r of each eccentric bearing from its maker's catalogue, N "
            "(default: ISO 281 from the needle geometry)",
            low=0,
            high=1e9,
            example=65000.0,
        ),
        "montecarlo_samples": Key(
            "int",
            200,
            "with a Monte Carlo: its first samples whose L10 percentiles are reported",
            low=0,
            high=1_000_000,
        ),
        "needles": Key(
            "int",
            40,
            "needles of each eccentric bearing (with [bearings.eccentric]: its value)",
            low=2,
            high=10000,
            low_open=False,
        ),
        "needle_diameter": Key(
            "float",
            6.0,
            "needle diameter D_we, mm (with [bearings.eccentric]: its value)",
            low=MIN_NEEDLE_MM,
            low_open=False,
            high=1000,
        ),
        "needle_length": Key(
            "float",
            12.0,
            "needle effective length L_we, mm (with [bearings.eccentric]: its value)",
            low=MIN_NEEDLE_MM,
            low_open=False,
            high=1000,
        ),
    },
}


def friction_sections(values: dict, data: dict, checks) -> dict:
    """``Scene.friction`` and ``Scene.life``: the sections with their defaults when given.

    Given means the scene has ``[friction]`` or ``[life]``, or a check that
    needs them (``min_efficiency``, ``min_life_h``); otherwise both are empty.
    ``[life]``'s needle keys are the fallback of ``[bearings.eccentric]``'s:
    both given with different values is refused in one line.
    """
    _same_needles(values, data)
    for key, works in (("efficiency_torques", "[0.5, 1.0]"), ("efficiency_speeds_rpm", "[1500]")):
        if values["friction"][key] == []:
            raise SceneError(
                f"[friction] {key} = []: give at least one value in "
                f"{key_range(SECTIONS['friction'][key])}, e.g. {key} = {works}"
            )
    given = (
        "friction" in data
        or "life" in data
        or "lubrication" in data  # the load-independent losses join the efficiency map
        or checks.min_efficiency is not None
        or checks.min_life_h is not None
    )
    return {
        "friction": values["friction"] if given else {},
        "life": values["life"] if given else {},
    }


#: ``[life]``'s needle geometry, also ``[bearings.eccentric]``'s keys.
NEEDLE_KEYS = ("needles", "needle_diameter", "needle_length")


def _same_needles(values: dict, data: dict) -> None:
    """Refuse ``[life]`` needle keys that contradict ``[bearings.eccentric]``'s."""
    life = data.get("life")
    bearing = values.get("bearings.eccentric") if "bearings.eccentric" in data else None
    if not isinstance(life, dict) or bearing is None:
        return
    for k in NEEDLE_KEYS:
        if k in life and bearing.get(k) is not None and life[k] != bearing[k]:
            raise SceneError(
                f"[life] {k} = {life[k]!r} contradicts [bearings.eccentric] {k} = "
                f"{bearing[k]!r}: the life rates the drive's bearing; remove [life] {k} "
                f"(or set it to {bearing[k]!r})"
            )
