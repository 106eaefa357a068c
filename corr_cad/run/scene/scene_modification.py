"""Parsing of ``[modification]`` and ``[assembly]`` (issue 20), called from
:func:`corr_cad.run.scene.scene.parse_scene`.

The normal table is a CSV file ``psi_deg,normal_mm`` (an optional header
line with exactly those names, ``#`` comments), read from the scene's folder.
Every refusal is one line naming the key (or the file and row), the value
and what works.
"""

from __future__ import annotations

from pathlib import Path

from corr_cad.bounds import show
from corr_cad.errors import CorrCadError, SceneError
from corr_cad.export.inputfiles import read_regular_file
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.modification import Modification, NormalTable, modified_profile

__all__ = [
    "acts",
    "parse_modification",
    "read_normal_table",
    "split_design_table",
    "MAX_TABLE_BYTES",
]

#: Largest normal table read (bytes).
MAX_TABLE_BYTES = 1024 * 1024


def read_normal_table(path: Path) -> NormalTable:
    """The table of ``path``: rows ``psi_deg,normal_mm``."""
    where = f"[modification] normal_table {show(path.name, 60)}"
    text = read_regular_file(path, "[modification] normal_table", MAX_TABLE_BYTES)
    try:
        lines = text.decode("utf-8-sig").splitlines()
    except UnicodeDecodeError as exc:
        raise SceneError(f"{where}: not UTF-8 text; write psi_deg,normal_mm rows") from exc
    for k, raw in enumerate(lines, start=1):  # never echo a binary or secret file's content
        if not raw.replace("\t", " ").isprintable():
            raise SceneError(
                f"{where} line {k}: holds control or NUL characters, not a text table (is it "
                "the right file?); write psi_deg,normal_mm rows, e.g. 90,0.005"
            )
    psi, nrm = [], []
    for k, raw in enumerate(lines, start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        cells = [c.strip() for c in line.replace(";", ",").split(",")]
        if not psi and [c.lower() for c in cells] == ["psi_deg", "normal_mm"]:
            continue
        if len(cells) != 2:
            raise SceneError(
                f"{where} line {k}: {len(cells)} columns; need psi_deg,normal_mm, e.g. 90,0.005"
            )
        try:
            psi.append(float(cells[0]))
            nrm.append(float(cells[1]))
        except ValueError as exc:
            raise SceneError(
                f"{where} line {k}: {quote_line(line)} is not two numbers psi_deg,normal_mm, "
                "e.g. 90,0.005"
            ) from exc
    try:
        return NormalTable(tuple(psi), tuple(nrm), source=f"normal_table {path.name}")
    except CorrCadError as exc:
        raise SceneError(f"[modification] {exc}") from exc


#: Most characters of a file's line quoted in a refusal.
QUOTE_CHARS = 40


def quote_line(line: str) -> str:
    """At most :data:`QUOTE_CHARS` printable characters of a line, quoted."""
    text = line if len(line) <= QUOTE_CHARS else line[: QUOTE_CHARS - 3] + "..."
    return repr(text)


def acts(section: str, modification, assembly: dict, search: dict) -> bool:
    """Whether a section of this module acts in the scene (only then is it recorded)."""
    if section == "modification":
        return modification is not None
    if section == "assembly":
        return bool(assembly)
    if section == "modification.design":
        return bool(search)
    return True


def split_design_table(data: dict) -> dict:
    """``[modification.design]`` (a table inside ``[modification]``) as its own section."""
    mod = data.get("modification") if isinstance(data, dict) else None
    if not (isinstance(mod, dict) and "design" in mod):
        return data
    if "modification.design" in data:  # one would silently override the other
        raise SceneError(
            '[modification.design] is given twice: as ["modification.design"] (quoted) and as '
            "[modification.design] or [modification] design = {...}; keep one of them"
        )
    rest = {k: v for k, v in mod.items() if k != "design"}
    return {**data, "modification": rest, "modification.design": mod["design"]}


def _design_search(values: dict, data: dict, load, formats: tuple) -> dict:
    """``[modification.design]`` values when the ``modification`` format runs, else {}."""
    md = values["modification.design"]
    if "modification" not in formats:
        return {}
    if md["target_backlash_arcmin"] is None:
        raise SceneError(
            "[export] formats lists 'modification' but [modification.design] "
            "target_backlash_arcmin is not set; e.g. target_backlash_arcmin = 2.0"
        )
    if not any(v is not None for v in values["tolerances"].values()):
        raise SceneError(
            "[export] formats lists 'modification' but [tolerances] is empty; the design "
            "searches under the tolerance scatter, e.g. roller_radius = { normal = 0.002 }"
        )
    if load is None and values["datasheet"].get("rated_torque_Nm") is None:
        raise SceneError(
            "[export] formats lists 'modification' but neither [load] input_torque nor "
            "[datasheet] rated_torque_Nm gives the rated torque"
        )
    for key in ("equidistant_range_mm", "shift_range_mm"):
        r = md[key]
        if len(r) != 2 or not r[0] < r[1]:
            raise SceneError(
                f"[modification.design] {key} = {r}: give two values, from < to, e.g. [0.0, 0.03]"
            )
    return dict(md)


def parse_modification(
    values: dict,
    data: dict,
    design: GearDesign,
    base_dir: Path | None,
    load=None,
    formats: tuple[str, ...] | None = None,
) -> tuple[Modification | None, dict, dict]:
    """``(modification or None, [assembly] values, [modification.design] values)``.

    ``formats``: the formats the scene runs (``["all"]`` expanded); default
    ``[export] formats`` as given.
    """
    if formats is None:
        formats = tuple(values["export"]["formats"])
    search = _design_search(values, data, load, formats)
    mv = values["modification"]
    mod = None
    if "modification" in data:
        table = None
        if mv["normal_table"] is not None:
            table = read_normal_table(Path(base_dir or ".") / mv["normal_table"])
        mod = Modification(mv["equidistant_mm"], mv["shift_mm"], table)
        half = 0.5 * design.roller_radius
        for key in ("equidistant_mm", "shift_mm"):
            if abs(mv[key]) >= half:
                raise SceneError(
                    f"[modification] {key} = {mv[key]:g}: allowed range is "
                    f"(-{half:g}, {half:g}) (half the roller radius), e.g. 0.01"
                )
        if mod.is_zero:  # an empty section (e.g. the commented template): the conjugate
            return None, _assembly(values, formats), search
        try:
            modified_profile(design, mod)
        except CorrCadError as exc:
            raise SceneError(str(exc)) from exc
    return mod, _assembly(values, formats), search


def _assembly(values: dict, formats: tuple) -> dict:
    """``[assembly]`` values; empty unless ``roller_classes_um`` is given."""
    asm = dict(values["assembly"])
    classes = asm["roller_classes_um"]
    if classes is None:
        return {}
    if not classes:
        raise SceneError(
            "[assembly] roller_classes_um is empty; give the classes you can buy, "
            "e.g. [-4.0, -2.0, 0.0, 2.0]"
        )
    if len(set(classes)) != len(classes):
        raise SceneError(f"[assembly] roller_classes_um = {classes}: lists a class twice")
    if "datasheet" not in formats:
        raise SceneError(
            '[assembly] roller_classes_um needs the datasheet: add "datasheet" to [export] formats'
        )
    return asm
