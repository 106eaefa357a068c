"""Wire-EDM G-code that a real control accepts (issue 18, item 2), for every dialect.

Each program is read by two independent strict readers: ``pygcode`` (a
third-party RS-274 parser: every word must be a known code or argument) and
:func:`check_program` below, which states the rules of this file's comments
and words from the dialect documentation, without the code under test. The
geometry is checked against the closed-form profile of ``tests/test_edm.py``.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from pygcode import Line

from corr_cad import SceneError, load_scene, run_scene
from corr_cad.run.scene.scene import parse_scene
from tests.test_edm import TOL, D, R, arc_points, distance, edm_run  # noqa: F401 (fixture)

DIALECTS = ("iso", "fanuc", "linuxcnc")
COMPS = ("path", "G41", "G42")

# --- the rules, from the controls' documentation -----------------------------

#: Codes each dialect may write (docs/_incoming/gcode.md), beside the scene's wire M-codes.
G_CODES = {
    "iso": {"G00", "G01", "G02", "G03", "G17", "G21", "G40", "G41", "G42", "G90"},
    "fanuc": {"G00", "G01", "G02", "G03", "G17", "G21", "G40", "G41", "G42", "G90"},
    "linuxcnc": {"G0", "G1", "G2", "G3", "G17", "G21", "G40", "G41", "G42", "G61", "G90", "G91.1"},
}
M_CODES = {"iso": {"M00", "M30"}, "fanuc": {"M00", "M30"}, "linuxcnc": {"M0", "M2"}}
END = {"iso": "M30", "fanuc": "M30", "linuxcnc": "M2"}
MOTION = {"G00": 0, "G01": 1, "G02": 2, "G03": 3, "G0": 0, "G1": 1, "G2": 2, "G3": 3}
#: Comment characters: Fanuc-style posts keep upper case letters, digits and " .,=_-".
COMMENT = {
    "iso": re.compile(r"[A-Za-z0-9 .,:=+\-_/*]+"),
    "fanuc": re.compile(r"[A-Z0-9 .,=_\-]+"),
    "linuxcnc": re.compile(r"[A-Za-z0-9 .,:=+\-_/*]+"),
}
#: LinuxCNC acts on comments starting with these (overview.adoc, "Comments").
ACTIVE = re.compile(r"\s*(msg|debug|print|log|probe|py|abort)", re.IGNORECASE)
INT_DIGITS = {"iso": 5, "fanuc": 4, "linuxcnc": 5}


def check_program(text: str, dialect: str, decimals: int = 4, wire_m: tuple = ()) -> list:
    """Apply the comment and word rules; returns ``(code words, comment)`` per line."""
    assert text.endswith("\n") and "\r" not in text and ";" not in text
    lines = text.split("\n")[:-1]
    pct = [i for i, ln in enumerate(lines) if "%" in ln]
    if dialect == "linuxcnc":
        assert pct == []  # the program ends with M2, no % needed
    else:
        assert pct == [0, len(lines) - 1] and lines[0] == lines[-1] == "%"
    number = re.compile(rf"-?\d{{1,{INT_DIGITS[dialect]}}}\.\d{{{decimals}}}")
    parsed, comp, idle, seen_motion = [], None, 0, False
    for k, ln in enumerate(lines):
        assert ln and len(ln) <= 80 and ln == ln.strip(), ln
        assert all(32 <= ord(c) < 127 for c in ln), ln
        if ln == "%":
            continue
        m = re.fullmatch(r"([^()]*?) ?(?:\(([^()]*)\))?", ln)
        assert m, f"not one flat comment at the end: {ln!r}"
        code, note = m.group(1), m.group(2)
        if note is not None:
            msg = dialect == "linuxcnc" and code == "M0" and note.startswith("MSG, ")
            body = note[5:] if msg else note
            assert body and body == body.strip() and COMMENT[dialect].fullmatch(body), ln
            assert msg or not ACTIVE.match(note), ln
        words = code.split()
        letters = [w[0] for w in words]
        assert all(letters.count(c) == 1 for c in set(letters) - {"G"}), ln
        for w in words:
            head, val = w[0], w[1:]
            if head == "G":
                assert w in G_CODES[dialect], ln
            elif head == "M":
                assert w in M_CODES[dialect] or w in wire_m, ln
            elif head in "XYIJ":
                assert number.fullmatch(val), ln
            elif head == "F":
                assert re.fullmatch(r"\d{1,5}\.\d\d", val) and 0.01 <= float(val) <= 10000, ln
            elif head == "D":
                assert re.fullmatch(r"[1-9]\d?", val), ln
            elif head == "O":
                assert dialect == "fanuc" and k == 1 and re.fullmatch(r"\d{4}", val), ln
                assert 1 <= int(val) <= 7999
            else:
                raise AssertionError(f"word {w!r} in {ln!r}")
        motions = [w for w in words if w in MOTION]
        assert len(motions) <= 1, ln
        if motions:
            assert {"X", "Y"} <= set(letters), ln
            assert ({"I", "J"} <= set(letters)) == (MOTION[motions[0]] in (2, 3)), ln
            if MOTION[motions[0]] != 0:
                assert {"G21", "G90", "G17"} <= {w for p in parsed for w in p[0]}
            seen_motion = True
        if "G40" in words and comp is None:  # the preamble cancels any compensation
            assert words == ["G40"] and not seen_motion, ln
        for g in ("G41", "G42", "G40"):
            if g in words and (g != "G40" or comp):  # on and off on a straight feed move only
                assert motions and MOTION[motions[0]] == 1 and seen_motion, ln
                assert (comp is None and "D" in letters) if g != "G40" else "D" not in letters
                comp = g if g != "G40" else None
        if comp is not None:  # Fanuc: no two blocks in a row without motion
            idle = 0 if motions else idle + 1
            assert idle < 2, f"two blocks without motion under {comp} at line {k + 1}"
        parsed.append((words, note))
    assert comp is None
    codes = [p[0] for p in parsed if p[0]]
    assert codes[-1] == [END[dialect]] and sum(END[dialect] in c for c in codes) == 1
    return parsed


def read_pygcode(text: str, wire_m: tuple = ()) -> list:
    """The second reader: every line parses and every word belongs to a known code."""
    out = []
    for ln in text.splitlines():
        if ln == "%":
            continue
        line = Line(ln)
        left = [str(w) for w in line.block.modal_params]
        assert all(w in wire_m for w in left), f"{ln!r}: unassigned words {left}"
        out.append({w.letter: w.value for w in line.block.words if w.letter in "XYIJFD"})
    return out


def trace(text: str) -> dict:
    """Moves by section (lead-in, contour, lead-out), from the text; arcs with centres."""
    pos, section, moves, feed = None, None, {}, None
    for k, ln in enumerate(text.splitlines()):
        low = ln.lower()
        if low in ("(lead-in)", "(contour)", "(lead-out)"):
            section = low.strip("()")
            continue
        code = ln.split("(")[0].split()
        w = {t[0]: t[1:] for t in code if t[0] != "G"}
        g = [t for t in code if t in MOTION]
        feed = float(w["F"]) if "F" in w else feed
        if not g:
            continue
        end = np.array([float(w["X"]), float(w["Y"])])
        if MOTION[g[0]] != 0:
            m = {"kind": MOTION[g[0]], "start": pos, "end": end, "words": code, "line": k}
            if m["kind"] in (2, 3):
                m["centre"] = pos + np.array([float(w["I"]), float(w["J"])])
            moves.setdefault(section, []).append(m)
        pos = end
    moves["feed"] = feed
    return moves


def points(moves: list, n: int = 16) -> np.ndarray:
    return np.concatenate(
        [
            arc_points(m, n)[0] if m["kind"] != 1 else np.linspace(m["start"], m["end"], n)
            for m in moves
        ]
    )


def length(m: dict) -> float:
    if m["kind"] == 1:
        return float(np.linalg.norm(m["end"] - m["start"]))
    return abs(arc_points(m)[1]) * float(np.linalg.norm(m["start"] - m["centre"]))


def winding(poly: np.ndarray, q: np.ndarray) -> int:
    """Winding number of the closed polygon ``poly`` around ``q``."""
    a = np.arctan2(*(poly - q).T[::-1])
    return round(float(np.sum(np.angle(np.exp(1j * (np.roll(a, -1) - a))))) / (2 * math.pi))


# --- the programs ------------------------------------------------------------


def run_in(folder: Path, name: str, edm: str, extra: str = "") -> Path:
    """Load and run a scene named ``name`` (its file stem) as the API user does."""
    folder.mkdir(parents=True, exist_ok=True)
    scene = folder / f"{name}.toml"
    scene.write_text(f'[export]\nformats = ["edm"]\n{extra}[edm]\n{edm}\n')
    out = folder / "out"
    out.mkdir()
    run_scene(load_scene(scene), out)
    return out


@pytest.fixture(scope="module")
def programs(tmp_path_factory) -> dict:
    """Every dialect with every compensation, default keys otherwise."""
    base = tmp_path_factory.mktemp("gcode")
    got = {}
    for dia in DIALECTS:
        for comp in COMPS:
            out = run_in(
                base / f"{dia}_{comp}", "gear", f'dialect = "{dia}"\ncompensation = "{comp}"'
            )
            man = json.loads((out / "manifest.json").read_text())
            got[dia, comp] = ((out / "inner_gear_edm.nc").read_text(), man["edm"])
    return got


@pytest.mark.slow
@pytest.mark.parametrize("dia", DIALECTS)
@pytest.mark.parametrize("comp", COMPS)
def test_both_readers_accept_every_dialect(programs, dia, comp):
    text, man = programs[dia, comp]
    lines = check_program(text, dia)
    values = read_pygcode(text)
    # the two readers agree on every coordinate, feed and register
    ours = [{w[0]: float(w[1:]) for w in words if w[0] in "XYIJFD"} for words, _ in lines]
    assert ours == values
    head = " ".join(n for _, n in lines if n)
    used = {w for words, _ in lines for w in words if w in ("G41", "G42")}
    assert used == (set() if comp == "path" else {comp})
    assert man["compensation"] == comp and man["gcode"]["dialect"] == dia
    if dia == "fanuc":
        assert text.startswith("%\nO1000 (") and head == head.upper()
    if dia == "linuxcnc":
        assert {"G91.1", "G61"} <= set(text.split()) and not text.startswith("%")
    stops = [w for w, _ in lines if w and w[0] in ("M00", "M0")]
    if dia == "iso":
        assert stops == [] and man["slug_stop_mm"] == 0.0  # the program as before
    else:  # thread the wire, then the slug stop
        assert len(stops) == 2 and man["slug_stop_mm"] == 1.0


@pytest.mark.slow
@pytest.mark.parametrize("comp", COMPS)
def test_path_is_the_profile_or_its_offset(programs, comp):
    """G41/G42: the programmed contour is the exact working profile; "path": at d from it."""
    for dia in DIALECTS:
        moves = trace(programs[dia, comp][0])
        pts = points(moves["contour"])
        to_profile = distance(pts, R)
        if comp == "path":
            assert distance(pts, R - D).max() <= TOL
            assert np.abs(to_profile - D).max() <= TOL  # wire radius + spark gap
        else:
            assert to_profile.max() <= TOL
        np.testing.assert_array_equal(moves["contour"][0]["start"], moves["contour"][-1]["end"])


@pytest.mark.slow
@pytest.mark.parametrize("dia", DIALECTS)
@pytest.mark.parametrize("comp", ("G41", "G42"))
def test_wire_side_is_the_scrap_and_the_offset_ramps_on_a_line(programs, dia, comp):
    text, man = programs[dia, comp]
    moves = trace(text)
    contour = moves["contour"]
    poly = points(contour)
    area = 0.5 * np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - np.roll(poly[:, 0], -1) * poly[:, 1])
    # G41 = wire left of the path in the direction of travel, G42 right.
    side = 1.0 if comp == "G41" else -1.0
    assert side * area > 0  # G41 runs counterclockwise, G42 clockwise
    for m in contour[:: max(1, len(contour) // 40)]:
        a, mid, b = points([m], 3)
        t = (b - a) / np.linalg.norm(b - a)  # the direction of travel at mid
        q = mid + side * 0.05 * np.array([-t[1], t[0]])
        assert winding(poly, q) != 0  # the wire side is inside the opening: the scrap
        assert distance(q[None, :], R)[0] == pytest.approx(0.05, abs=0.002)
    assert man["cut_direction"] == ("counterclockwise" if comp == "G41" else "clockwise")
    on, arc = moves["lead-in"]
    off = moves["lead-out"][-1]
    assert comp in on["words"] and "D1" in on["words"] and on["kind"] == 1
    assert "G40" in off["words"] and off["kind"] == 1
    # LinuxCNC: lead-in at least the radius, the move after G40 longer than the diameter
    assert length(on) > 2 * D and length(off) > 2 * D
    assert np.linalg.norm(arc["start"] - arc["centre"]) > D  # the lead-in arc fits the offset


@pytest.mark.slow
@pytest.mark.parametrize("dia", DIALECTS)
def test_slug_stop_leaves_the_stated_length(programs, dia):
    text = programs[dia, "G42"][0]
    lines = text.splitlines()
    stops = [i for i, ln in enumerate(lines) if ln.split("(")[0].strip() in ("M00", "M0")]
    if dia == "iso":
        assert stops == []
        return
    k = stops[-1]
    assert "slug" in lines[k].lower() and "1 mm" in lines[k].lower()
    tail = [m for m in trace(text)["contour"] if m["line"] > k]
    assert sum(length(m) for m in tail) == pytest.approx(1.0, abs=0.01)


@pytest.mark.slow
def test_the_program_with_forces_reads_strictly(edm_run):  # noqa: F811 (the fixture)
    """tests/test_edm.py's run: lead-in on a flank, chosen by the solver (the old nested text)."""
    out, _ = edm_run
    text = (out / "inner_gear_edm.nc").read_text()
    lines = check_program(text, "iso")
    read_pygcode(text)
    notes = [n for _, n in lines if n]
    assert "chosen by solver: least peak gear force over the cycle, 720 bins of psi" in notes


@given(st.sampled_from(DIALECTS), st.text(max_size=300), st.sampled_from(["", "msg, ", " Debug"]))
def test_any_text_becomes_flat_comments(dia, text, lead):
    from corr_cad.export.gcode import DIALECTS as WRITER
    from corr_cad.export.gcode import comment_lines

    lines = comment_lines(lead + text, WRITER[dia])
    for ln in lines:
        (note,) = re.fullmatch(r"\(([^()]*)\)", ln).groups()
        assert len(ln) <= 80 and note == note.strip() and COMMENT[dia].fullmatch(note), ln
        assert not ACTIVE.match(note), ln
    assert ";" not in "".join(lines) and "%" not in "".join(lines)


# --- hostile scene names -----------------------------------------------------

HOSTILE = [
    "gear)\nG00 X500 Y500\n(",
    "a;b%c (MSG, hi)",
    "LOGOPEN,x",
    "Zahnrad-\u00fc-\u6b6f\u8eca",
    "x" * 200,
    "))((",
    "\t",
]


@pytest.fixture(scope="module")
def planned():
    """One wire path; the names only change the writer's header."""
    from corr_cad import GearDesign
    from corr_cad.geometry.profile import working_profile
    from corr_cad.shop.edm import EdmSpec, plan_cut

    prog, _ = plan_cut(
        working_profile(GearDesign()), EdmSpec(compensation="G42", slug_stop_mm=1.0), 0.001
    )
    return prog


@pytest.mark.parametrize("dia", DIALECTS)
@pytest.mark.parametrize("name", HOSTILE, ids=range(len(HOSTILE)))
def test_hostile_scene_names_stay_in_one_flat_comment(tmp_path, planned, dia, name):
    from corr_cad import GearDesign
    from corr_cad.export.gcode import GcodeOptions, write_gcode

    opts = GcodeOptions(dialect=dia)
    write_gcode(GearDesign(), planned, name, tmp_path / "h.nc", opts)
    write_gcode(GearDesign(), planned, "plain", tmp_path / "p.nc", opts)
    hostile = (tmp_path / "h.nc").read_text()
    plain = (tmp_path / "p.nc").read_text()
    check_program(hostile, dia)
    read_pygcode(hostile)
    h, p = hostile.splitlines(), plain.splitlines()
    diff = [i for i, (a, b) in enumerate(zip(h, p, strict=True)) if a != b]
    assert len(h) == len(p) and len(diff) <= 1  # only the line naming the scene
    assert not any("X500" in ln.split("(")[0] for ln in h)  # nothing injected into the code


@pytest.mark.slow
def test_hostile_file_name_through_the_cli(tmp_path):
    name = "gear)\nG00 X500 Y500\n(x"
    scene = tmp_path / f"{name}.toml"
    scene.write_text('[export]\nformats = ["edm"]\n[edm]\ndialect = "fanuc"\n')
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    text = (tmp_path / "out" / "inner_gear_edm.nc").read_text()
    check_program(text, "fanuc")
    read_pygcode(text)
    assert not any("X500" in ln.split("(")[0] for ln in text.splitlines())
    assert "(CORR_CAD 0.1.0 WIRE EDM PROGRAM, SCENE GEAR_G00_X500_Y500_X)" in text


# --- keys, numbers and refusals ----------------------------------------------


@pytest.mark.slow
def test_feed_is_fixed_point_and_wire_mcodes_are_written(tmp_path):
    out = run_in(
        tmp_path / "m",
        "gear",
        'dialect = "fanuc"\nfeed_mm_per_min = 3.456\nwire_thread_mcode = 50\n'
        "wire_cut_mcode = 60\nslug_stop_mm = 0\nprogram_number = 12\n",
    )
    text = (out / "inner_gear_edm.nc").read_text()
    lines = check_program(text, "fanuc", wire_m=("M50", "M60"))
    read_pygcode(text, wire_m=("M50", "M60"))
    codes = [w for w, _ in lines if w]
    assert trace(text)["feed"] == 3.46 and " F3.46" in text
    assert text.startswith("%\nO0012 (")
    rapid = next(i for i, w in enumerate(codes) if w[0] == "G00")
    assert codes[rapid + 1] == ["M50"] and codes[-2:] == [["M60"], ["M30"]]
    assert "M00" not in text  # no slug stop, threading by M50
    out = run_in(tmp_path / "l", "gear", 'dialect = "linuxcnc"\nwire_thread_mcode = 101\n')
    text = (out / "inner_gear_edm.nc").read_text()
    check_program(text, "linuxcnc", wire_m=("M101",))
    read_pygcode(text, wire_m=("M101",))
    out = run_in(tmp_path / "i", "gear", "slug_stop_mm = 2.5\n")
    text = (out / "inner_gear_edm.nc").read_text()
    check_program(text, "iso")
    assert text.count("\nM00 (slug stop: 2.5 mm uncut") == 1


BAD = [
    ({"dialect": "heidenhain"}, "", r"\[edm\] dialect = 'heidenhain': must be one of iso, fanuc"),
    ({"compensation": "G43"}, "", r"compensation = 'G43': must be one of path, G41, G42"),
    ({"d_register": 0}, "", r"\[edm\] d_register = 0: allowed range is \[1, 99\]"),
    ({"program_number": 9000}, "", r"program_number = 9000: allowed range is \[1, 7999\]"),
    ({"feed_mm_per_min": 1e-5}, "", r"feed_mm_per_min = 1e-05: allowed range is \[0.01, 10000\]"),
    (
        {"dialect": "fanuc"},
        "tolerance = 0.0005\n",
        r'\[export\] tolerance = 0.0005: \[edm\] dialect = "fanuc" writes at most 4 decimals.*'
        r"allowed range is \[0.001, 10\], e.g. tolerance = 0.001",
    ),
    (
        {"compensation": "G42", "lead_in_length": 0.5},
        "",
        r'lead_in_length = 0.5: with compensation = "G42" .* allowed range is \(0.58, 50\], '
        r"e.g. lead_in_length = 2",
    ),
    ({"dialect": "fanuc", "wire_thread_mcode": 30}, "", r"wire_thread_mcode = 30: .*e.g. 50"),
    ({"dialect": "linuxcnc", "wire_cut_mcode": 60}, "", r"wire_cut_mcode = 60: LinuxCNC has no"),
    (
        {"wire_thread_mcode": 50, "wire_cut_mcode": 50},
        "",
        r"wire_cut_mcode = 50: the same as wire_thread_mcode",
    ),
    ({"slug_stop_mm": 0.05}, "", r"slug_stop_mm = 0.05: allowed range is 0 \(no slug stop\)"),
]


@pytest.mark.parametrize("edm,export,pattern", BAD, ids=[str(b[0]) for b in BAD])
def test_bad_edm_keys_get_one_line(edm, export, pattern):
    data = {"export": {"formats": ["edm"]}, "edm": edm}
    if export:
        data["export"]["tolerance"] = float(export.split("=")[1])
    with pytest.raises(SceneError, match=pattern) as err:
        parse_scene(data)
    assert "\n" not in str(err.value)


def test_design_beyond_the_fanuc_range_is_refused_and_iso_takes_it():
    design = {"cam_radius": 9990.0, "roller_radius": 8.0}
    with pytest.raises(SceneError, match=r'dialect = "fanuc": coordinates up to 9999.9999 mm'):
        parse_scene({"design": design, "export": {"formats": ["edm"]}, "edm": {"dialect": "fanuc"}})
    parse_scene({"design": design, "export": {"formats": ["edm"]}, "edm": {"dialect": "iso"}})


def test_keys_without_effect_warn():
    s = parse_scene({"export": {"formats": ["edm"]}, "edm": {"d_register": 3, "program_number": 7}})
    assert any(w.startswith("[edm] d_register has no effect") for w in s.warnings)
    assert any(w.startswith("[edm] program_number has no effect") for w in s.warnings)
    s = parse_scene({"export": {"formats": ["edm"], "tolerance": 0.002}})
    assert not s.warnings  # [export] tolerance is the wire path's
