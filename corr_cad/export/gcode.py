"""Wire-EDM G-code (``inner_gear_edm.nc``) in the dialect of the control that runs it.

Three dialects (``[edm] dialect``), each emitting only codes whose meaning
its documentation states; ``docs/_incoming/gcode.md`` lists them:

``iso``
    Generic ISO 6983 / RS-274, the program corr_cad always wrote: ``%`` on
    the first and last line, G21 G90 G17 G40, G00/G01/G02/G03 with I, J
    incremental from the arc start, M30. No operator stops unless asked for.
``fanuc``
    Fanuc-style wire EDM: ``%``, an O program number, comments in upper case
    from the character set Fanuc-style controls read, coordinates with 4
    decimals (increment system IS-C, 0.0001 mm, at most 8 digits), M00
    operator stops (thread the wire, slug stop), M30.
``linuxcnc``
    LinuxCNC (RS-274/NGC): no ``%`` (the program ends with M2), G91.1
    (I, J incremental) and G61 (exact path) in the preamble, operator stops
    as ``M0 (MSG, ...)`` so the screen says what to do.

Every line is printable ASCII, at most :data:`MAX_LINE` characters; a
comment is one flat pair of parentheses at the end of its line (no nested
parentheses, no ``;``, no ``%``, never starting like a LinuxCNC active
comment unless it is an operator message); the scene name is reduced to
``[A-Za-z0-9._-]``. Every word is checked against the dialect's range before
it is written.
"""

from __future__ import annotations

import re
import string
import textwrap
from dataclasses import dataclass
from pathlib import Path

from corr_cad._version import __version__
from corr_cad.errors import SceneError
from corr_cad.export.files import _atomic_text
from corr_cad.geometry.design import GearDesign
from corr_cad.shop.edm import (
    EdmProgram,
    EdmSpec,
    Move,
    check_lead_in,
    check_lead_in_steps,
    gcode_decimals,
)

__all__ = [
    "DIALECTS",
    "DIALECT_NAMES",
    "MAX_LINE",
    "Dialect",
    "GcodeOptions",
    "check_edm_scene",
    "comment_lines",
    "scene_label",
    "write_gcode",
]

#: Longest line written (LinuxCNC reads 256; 80 keeps every control and screen safe).
MAX_LINE = 80
#: Feed words: mm/min with 2 decimals, in this range.
FEED_DECIMALS, FEED_MIN, FEED_MAX = 2, 0.01, 10000.0
#: D register / LinuxCNC tool number range.
D_MIN, D_MAX = 1, 99
#: Fanuc program numbers (O8000-O9999 are often edit-protected).
O_MIN, O_MAX = 1, 7999

_ISO_CHARS = frozenset(string.ascii_letters + string.digits + " .,:=+-_/*")
# The comment characters Fanuc-style posts keep (everything else is mapped or dropped).
_FANUC_CHARS = frozenset(string.ascii_uppercase + string.digits + " .,=_-")
# LinuxCNC acts on comments that start with these words (MSG, DEBUG, PRINT, LOG..., PROBE...).
_ACTIVE = re.compile(r"\s*(msg|debug|print|log|probe|py|abort)", re.IGNORECASE)


@dataclass(frozen=True)
class Dialect:
    """What one control reads: codes, number format, comments, operator stops."""

    name: str
    percent: bool  # "%" on the first and the last line
    program_number: bool  # an O word after the first "%"
    rapid: str
    line: str
    cw: str
    ccw: str
    stop: str  # program stop (operator action)
    end: str  # program end
    preamble: tuple[str, ...]
    max_decimals: int  # most decimals of a coordinate
    int_digits: int  # most digits before the decimal point
    upper: bool  # comments in upper case
    chars: frozenset  # characters a comment may hold
    operator_stops: bool  # stop for threading and the slug by default
    message: str  # prefix of an operator message comment
    slug_stop_mm: float  # default [edm] slug_stop_mm
    wire_mcodes: tuple[int, int]  # M-codes a scene may give for threading and cutting
    reserved_mcodes: frozenset  # ... except these (program flow)

    @property
    def max_abs(self) -> float:
        """Largest coordinate magnitude at the most decimals."""
        return 10.0**self.int_digits - 10.0**-self.max_decimals

    def mcode(self, n: int) -> str:
        return f"M{n}" if self.name == "linuxcnc" else f"M{n:02d}"


_FLOW = frozenset({30, 98, 99})
DIALECTS: dict[str, Dialect] = {
    "iso": Dialect(
        "iso", True, False, "G00", "G01", "G02", "G03", "M00", "M30",
        ("G21", "G90", "G17", "G40"), 6, 5, False, _ISO_CHARS, False, "", 0.0,
        (3, 999), _FLOW,
    ),
    "fanuc": Dialect(
        "fanuc", True, True, "G00", "G01", "G02", "G03", "M00", "M30",
        ("G21", "G90", "G17", "G40"), 4, 4, True, _FANUC_CHARS, True, "", 1.0,
        (3, 999), _FLOW,
    ),
    "linuxcnc": Dialect(
        "linuxcnc", False, False, "G0", "G1", "G2", "G3", "M0", "M2",
        ("G21", "G90", "G91.1", "G17", "G40", "G61"), 6, 5, False, _ISO_CHARS, True, "MSG, ",
        1.0, (100, 199), frozenset(),
    ),
}  # fmt: skip
DIALECT_NAMES = tuple(DIALECTS)


@dataclass(frozen=True)
class GcodeOptions:
    """The ``[edm]`` keys only the G-code writer reads."""

    dialect: str = "iso"
    d_register: int = 1
    program_number: int = 1000
    wire_thread_mcode: int | None = None
    wire_cut_mcode: int | None = None


def needed_decimals(tolerance: float) -> int:
    """Decimals the wire path needs: a number quantum at most a tenth of the tolerance.

    :func:`corr_cad.shop.edm.gcode_decimals` (``tolerance / 10`` of a subnormal
    tolerance is 0, whose logarithm is a math domain error: it takes
    ``1 - log10(tolerance)``).
    """
    return gcode_decimals(tolerance)


def check_edm_scene(edm: dict, tolerance: float, design: GearDesign) -> None:
    """What the scene loader checks when formats lists "edm" (one SceneError line each)."""
    d = DIALECTS[edm["dialect"]]
    who = f'[edm] dialect = "{d.name}"'
    if needed_decimals(tolerance) > d.max_decimals:
        low = 10.0 ** (1 - d.max_decimals)
        raise SceneError(
            f"[export] tolerance = {tolerance:g}: {who} writes at most {d.max_decimals} "
            f"decimals, so the wire path needs a tolerance of at least {low:g} mm; allowed range "
            f"is [{low:g}, 10], e.g. tolerance = 0.001"
        )
    reach = design.eccentricity + design.link_length + design.roller_radius
    if reach > d.max_abs:
        raise SceneError(
            f"{who}: coordinates up to {d.max_abs:.{d.max_decimals}f} mm ({d.int_digits} digits "
            f"before the point), but the profile reaches {reach:.6g} mm from the axis "
            f'(e + Rj + 2r); use dialect = "iso" or "linuxcnc"'
        )
    codes = {}
    for key in ("wire_thread_mcode", "wire_cut_mcode"):
        n = edm[key]
        if n is None:
            continue
        lo, hi = d.wire_mcodes
        if d.name == "linuxcnc" and not lo <= n <= hi:
            raise SceneError(
                f"[edm] {key} = {n}: LinuxCNC has no wire M-codes (M{n} means something else "
                f"there or nothing); allowed range is [{lo}, {hi}], the user M-codes of your "
                "configuration, e.g. 101; without the key the program stops with M0"
            )
        if n in d.reserved_mcodes or not lo <= n <= hi:
            raise SceneError(
                f"[edm] {key} = {n}: {who} allows [{lo}, {hi}] except "
                f"{', '.join(f'M{c}' for c in sorted(d.reserved_mcodes))} (program end and "
                "subprograms); take the code from your machine's M-code list, e.g. 50"
            )
        codes[key] = n
    if len(codes) == 2 and len(set(codes.values())) == 1:
        n = codes["wire_cut_mcode"]
        raise SceneError(
            f"[edm] wire_cut_mcode = {n}: the same as wire_thread_mcode; threading and cutting "
            "need different M-codes, e.g. wire_thread_mcode = 50, wire_cut_mcode = 60"
        )
    slug = edm["slug_stop_mm"]
    if slug is not None and 0.0 < slug < 0.1:
        raise SceneError(
            f"[edm] slug_stop_mm = {slug:g}: allowed range is 0 (no slug stop) or [0.1, 50], "
            "e.g. slug_stop_mm = 1"
        )
    check_lead_in(
        EdmSpec(
            wire_diameter=edm["wire_diameter"],
            spark_gap=edm["spark_gap"],
            lead_in_length=edm["lead_in_length"],
            compensation=edm["compensation"],
        )
    )
    check_lead_in_steps(edm["lead_in_length"], tolerance)  # its arc on the coordinate grid


def scene_label(name: str) -> str | None:
    """The scene name as a comment may show it: ``[A-Za-z0-9._-]``, 32 characters; or None."""
    s = re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("_.-")[:32]
    return s if re.search(r"[A-Za-z0-9]", s) else None


def _flat(text: str, d: Dialect) -> str:
    t = text.replace("(", ", ").replace(")", "").replace(";", ",").replace("%", " percent")
    if d.upper:
        t = t.upper()
        for a, b in ((":", ","), ("+", " PLUS "), ("/", "-"), ("*", " X ")):
            t = t.replace(a, b)
    t = "".join(c if c in d.chars else "_" for c in t)
    t = re.sub(r"\s*,[\s,]*", ", ", re.sub(r"\s+", " ", t)).strip(" ,")
    return "- " + t if _ACTIVE.match(t) else t


def comment_lines(text: str, d: Dialect) -> list[str]:
    """``text`` as flat comment lines of the dialect, wrapped at :data:`MAX_LINE`."""
    width, lines, cur = MAX_LINE - 2, [], ""
    for clause in _flat(text, d).split(", "):  # break between clauses, words if need be
        if cur and len(cur) + 2 + len(clause) <= width:
            cur += ", " + clause
            continue
        if cur:
            lines.append(cur)
        *full, cur = textwrap.wrap(clause, width, break_on_hyphens=False) or [""]
        lines += full
    return [f"({part})" for part in lines + [cur] if part]


class _Lines:
    """The program being written; every word is range-checked here."""

    def __init__(self, d: Dialect, decimals: int):
        if decimals > d.max_decimals:
            raise SceneError(
                f'[edm] dialect = "{d.name}": the wire path needs {decimals} decimals, the '
                f"control reads {d.max_decimals}; raise [export] tolerance, e.g. to 0.001"
            )
        self.d, self.dec, self.out = d, decimals, []

    def comment(self, text: str) -> None:
        self.out += comment_lines(text, self.d)

    def block(self, *words: str, note: str = "", message: bool = False) -> None:
        text = " ".join(words)
        if note:
            flat = _flat(note, self.d)
            text += f" ({self.d.message + flat if message else flat})"
        if len(text) > MAX_LINE:
            raise AssertionError(f"G-code line longer than {MAX_LINE}: {text!r}")
        self.out.append(text)

    def num(self, letter: str, v: float) -> str:
        s = f"{v:.{self.dec}f}"
        if not abs(float(s)) <= self.d.max_abs:
            raise SceneError(
                f'[edm] dialect = "{self.d.name}": {letter}{s} is beyond the control\'s range '
                f'+-{self.d.max_abs:.{self.d.max_decimals}f} mm; use dialect = "iso" or "linuxcnc"'
            )
        return f"{letter}{s}"

    def feed(self, v: float) -> str:
        s = f"{v:.{FEED_DECIMALS}f}"
        if not FEED_MIN <= float(s) <= FEED_MAX:
            raise SceneError(
                f"[edm] feed_mm_per_min = {v:g}: written as F{s}; allowed range is "
                f"[{FEED_MIN:g}, {FEED_MAX:g}], e.g. feed_mm_per_min = 2"
            )
        return f"F{s}"

    def integer(self, letter: str, n: int, lo: int, hi: int, key: str) -> str:
        if not (isinstance(n, int) and lo <= n <= hi):
            raise SceneError(f"[edm] {key} = {n!r}: allowed range is [{lo}, {hi}]")
        return f"{letter}{n:04d}" if letter == "O" else f"{letter}{n}"

    def move(self, m: Move, pre: tuple[str, ...] = (), post: tuple[str, ...] = ()) -> None:
        """One move; ``pre`` G-codes after the motion code, ``post`` words after the axes."""
        if m.start == m.end:  # an arc would be a full circle, a line nothing
            raise AssertionError(f"zero-length move at {m.start}")
        xy = [self.num("X", m.end[0]), self.num("Y", m.end[1])]
        if m.kind == "line":
            self.block(self.d.line, *pre, *xy, *post)
            return
        if pre:  # no control starts or ends compensation on an arc
            raise AssertionError("G40/G41/G42 on an arc")
        ij = [self.num(k, c - s) for k, c, s in zip("IJ", m.centre, m.start, strict=True)]
        self.block(self.d.cw if m.clockwise else self.d.ccw, *xy, *ij, *post)


def _header(
    w: _Lines, design: GearDesign, prog: EdmProgram, label: str | None, o: GcodeOptions
) -> None:
    d, spec, dg = w.d, prog.spec, design
    comp, off = spec.compensation, spec.offset
    li = prog.lead_in_point
    peak = li.get("peak_gear_force_N")
    load = f", peak gear force there {peak:.4g} N" if peak is not None else ""
    hx, hy = (f"{v:.{w.dec}f}" for v in prog.start_hole_centre)
    w.comment(f"corr_cad {__version__} wire EDM program" + (f", scene {label}" if label else ""))
    w.comment(
        f"part: inner gear, z = {dg.tooth_count}, e = {dg.eccentricity:g}, "
        f"Rj = {dg.cam_radius:g}, r = {dg.roller_radius:g}, L = Rj + r = {dg.link_length:g} mm"
    )
    kind = "modified" if prog.modified else "conjugate"
    if prog.profile:
        w.comment(f"profile: {prog.profile}")
    w.comment("units mm, absolute, XY plane, origin on the gear axis, tooth space 1 on +Y")
    w.comment(f"wire diameter {spec.wire_diameter:g} mm + spark gap {spec.spark_gap:g} mm")
    if comp == "path":
        w.comment(f"wire centre offset {off:g} mm into the opening, the scrap side")
        w.comment("offset already in the path: no G41/G42 compensation")
        w.comment(f"contour: exact offset of the exact {kind} working profile by {off:g} mm")
        curve = "the exact offset curve"
    else:
        side = "left" if comp == "G41" else "right"
        limit = min(0.25 * spec.lead_in_length, prog.smallest_concave_radius)
        reg = f"D{o.d_register}"
        w.comment(f"compensation {comp} {reg}: the wire runs {side} of the path, in the opening")
        if d.name == "linuxcnc":
            w.comment(
                f"{reg} = tool {o.d_register} of the tool table, diameter {2 * off:g} mm, "
                f"below {2 * limit:.4g} mm"
            )
        else:
            w.comment(f"set {reg} to wire radius + spark gap = {off:g} mm, below {limit:.4g} mm")
        w.comment(f"contour: the exact {kind} working profile, the finished part")
        curve = "the exact profile"
    w.comment(f"tangent-continuous arcs, tolerance {prog.tolerance:g} mm")
    w.comment(f"measured max deviation of this path from {curve}: {prog.written_deviation:.3g} mm")
    w.comment(
        f"smallest concave radius seen from the scrap side: {prog.smallest_concave_radius:.6g} mm"
    )
    w.comment(f"start hole: diameter {spec.start_hole_diameter:g} mm at X{hx} Y{hy}")
    w.comment(f"lead-in: tangent at the {li['where']}")
    w.comment(f"chosen by {li['source']}{load}")
    if prog.slug_stop_index is not None:
        w.comment(f"slug stop: program stop {spec.slug_stop_mm:g} mm before the contour closes")
    w.comment(
        f"cut direction: {'clockwise' if spec.clockwise else 'counterclockwise'} seen from +Z"
    )


def gcode_lines(
    design: GearDesign, prog: EdmProgram, scene_name: str, options: GcodeOptions
) -> list[str]:
    """The program, line by line."""
    d = DIALECTS[options.dialect]
    w = _Lines(d, prog.decimals)
    if d.percent:
        w.out.append("%")
    if d.program_number:
        pn = w.integer("O", options.program_number, O_MIN, O_MAX, "program_number")
        w.block(pn, note="inner gear wire EDM")
    _header(w, design, prog, scene_label(scene_name), options)
    for code in d.preamble:
        w.block(code)
    hole = [w.num("X", prog.start_hole_centre[0]), w.num("Y", prog.start_hole_centre[1])]
    w.block(d.rapid, *hole, note="start hole centre: thread the wire here")
    if options.wire_thread_mcode is not None:
        w.block(d.mcode(options.wire_thread_mcode), note="thread the wire")
    elif d.operator_stops:
        w.block(d.stop, note="thread the wire at the start hole, then cycle start", message=True)
    comp = prog.spec.compensation
    on = (comp,) if comp != "path" else ()
    d_word = (w.integer("D", options.d_register, D_MIN, D_MAX, "d_register"),) if on else ()
    w.comment("lead-in")
    w.move(prog.lead_in[0], on, (*d_word, w.feed(prog.spec.feed_mm_per_min)))
    for m in prog.lead_in[1:]:
        w.move(m)
    w.comment("contour")
    for i, m in enumerate(prog.contour):
        if i == prog.slug_stop_index:
            tab = (
                f"slug stop: {prog.spec.slug_stop_mm:g} mm uncut, secure the slug, then cycle start"
            )
            w.block(d.stop, note=tab, message=True)
        w.move(m)
    w.comment("lead-out")
    for m in prog.lead_out[:-1]:
        w.move(m)
    w.move(prog.lead_out[-1], ("G40",) if on else ())
    if options.wire_cut_mcode is not None:
        w.block(d.mcode(options.wire_cut_mcode), note="cut the wire")
    elif d.operator_stops:
        w.comment("end: cut the wire, take out the slug and the part")
    w.block(d.end)
    if d.percent:
        w.out.append("%")
    return w.out


def write_gcode(
    design: GearDesign,
    prog: EdmProgram,
    scene_name: str,
    path: Path,
    options: GcodeOptions | None = None,
) -> Path:
    """Write the program (G17 XY plane, G01/G02/G03, I and J incremental from the arc start)."""
    lines = gcode_lines(design, prog, scene_name, options or GcodeOptions())
    return _atomic_text(Path(path), "\n".join(lines) + "\n")
