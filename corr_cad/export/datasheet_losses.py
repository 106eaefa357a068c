"""The datasheet page's rows of the load-independent losses and the temperature:
total efficiency, starting torque with drag, modified life, thermal rating, the
temperature test (``[lubrication]``, ``[thermal]``)."""

from __future__ import annotations

from corr_cad.figure_text import catalogue_number

__all__ = ["losses_rows"]


def losses_rows(sheet: dict) -> list[tuple]:
    """``[lubrication]`` / ``[thermal]`` rows: total efficiency, starting torque, L10m,
    thermal rating, the temperature test (none without ``[lubrication]``)."""
    if "efficiency_total" not in sheet:
        return []
    e, lub = sheet["efficiency_total"], sheet["lubrication"]
    n = catalogue_number
    rows = [
        (
            "Efficiency, total (lowest of the map)",
            "efficiency_total.forward_min",
            "",
            "output over input power with Coulomb friction, Palmgren bearing drag, seals"
            f"{', churning' if 'churning' in sheet['load_independent_losses'] else ''}, "
            f"over {n(min(e['temperatures_C']))}-{n(max(e['temperatures_C']))} C oil, "
            f"{n(min(e['input_speed_rpm']))}-{n(max(e['input_speed_rpm']))} rpm at the crank "
            f"and the map's torques ({lub['source']})",
        ),
        (
            "Starting torque at the input",
            "starting_torque_total_Nm.at_input",
            "N*m",
            "bearing drag at standstill (Palmgren) and seals, plus preload friction",
        ),
    ]
    for tag, m in sheet.get("modified_life", {}).items():
        if isinstance(m, dict) and m.get("L10m_h") is not None:
            rows.append(
                (
                    f"Modified life L10m, {tag.replace('_', ' ')}",
                    f"modified_life.{tag}.L10m_h",
                    "h",
                    f"ISO 281:2007 a_ISO = {n(m['a_ISO'], 3)} (kappa {n(m['kappa'], 3)}) "
                    f"times L10 at T_R, {n(lub['temperature_C'])} C oil",
                )
            )
    rating = sheet.get("thermal", {}).get("thermal_rating", {})
    if rating.get("input_speed_at_rated_torque_rpm") is not None:
        rows.append(
            (
                "Thermal rating at T_R",
                "thermal.thermal_rating.input_speed_at_rated_torque_rpm",
                "rpm",
                f"crank speed at which the steady oil temperature reaches "
                f"{n(rating['max_oil_temperature_C'])} C (ISO/TR 14179-1 heat balance)",
            )
        )
    if "thermal_test" in sheet:
        rows.append(
            (
                "Temperature test, final",
                "thermal_test.final_temperature_C",
                "C",
                f"oil temperature after the {n(sheet['thermal_test']['duration_min'])} min "
                "programme of [thermal.test] (temperature.csv)",
            )
        )
    return rows
