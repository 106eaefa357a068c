"""Hostile input and hostile surroundings, each through the real command line.

Every test runs ``python -m corr_cad`` in its own process, in a folder that
holds the user's other files. A refused run prints exactly one line, never
cut, exits 2, writes nothing and leaves the user's files
alone; an interrupt ends the run as ``docs/output-folder.md`` says (one
line, exit 130). No test waits on a clock: each acts on an event (a line
on stderr, a file that appears); the time-outs only guard against a hang.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import without_progress
from tests.test_inputs_issue21 import DESIGN, cli  # the z = 8 design, the CLI in s.toml

#: Longest a single run may take before the test calls it a hang.
HANG_S = 600


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "notes.txt").write_text("mine\n")
    return tmp_path


def refused(folder: Path, r, *also: str) -> str:
    """The one error line of a refused run (exit 2, nothing written, no traceback)."""
    assert r.returncode == 2, (r.returncode, r.stderr[-3000:])
    assert "Traceback" not in r.stderr and "Warning" not in r.stderr, r.stderr[-3000:]
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr[-3000:]
    assert " ... " not in lines[0], lines[0]  # a refusal is never cut
    assert lines[0].startswith("corr-cad: error: ")
    assert sorted(p.name for p in folder.iterdir()) == sorted(["notes.txt", "s.toml", *also])
    assert (folder / "notes.txt").read_text() == "mine\n"
    return lines[0]


def warnings_of(r) -> list[str]:
    return [ln for ln in r.stderr.splitlines() if ln.startswith("corr-cad: warning: ")]


# --- the command line itself ---------------------------------------------------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["run"],
        ["run", "s.toml", "--bogus"],
        ["run", "s.toml", "--workers", "many"],
        ["run", "s.toml", "--executor", "cloud"],
        ["frobnicate"],
        [],
    ],
)
def test_a_flag_error_is_one_line_and_exit_2(folder, argv):
    (folder / "s.toml").write_text(DESIGN)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", *argv],
        capture_output=True,
        text=True,
        cwd=folder,
        timeout=HANG_S,
    )
    line = refused(folder, r)
    assert "usage:" not in r.stderr
    assert "--help" in line


def test_sigint_while_the_command_starts_is_one_line(folder):
    """Ctrl-C while numpy and scipy load (the first 0.7 s): no KeyboardInterrupt traceback.

    ``-X importtime`` prints a line as each module finishes loading: the
    signal goes out when numpy is in, scipy and the rest still to come.
    """
    (folder / "s.toml").write_text(DESIGN)
    p = subprocess.Popen(
        [sys.executable, "-X", "importtime", "-m", "corr_cad", "run", "s.toml", "--out", "out"],
        cwd=folder,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    seen = []
    try:
        for line in p.stderr:
            seen.append(line)
            if line.rstrip().split("|")[-1].strip() == "numpy":
                p.send_signal(signal.SIGINT)
                break
        seen.append(p.stderr.read())
        p.wait(timeout=HANG_S)
    finally:
        p.kill()
    lines = [ln for ln in "".join(seen).splitlines() if not ln.startswith("import time:")]
    assert p.returncode == 130, lines
    assert lines == ["corr-cad: interrupted (SIGINT); previous outputs left as they were"]
    assert sorted(x.name for x in folder.iterdir()) == ["notes.txt", "s.toml"]


@pytest.mark.parametrize("module", ["corr_cad._startup", "numpy", "scipy", "corr_cad.run.cli"])
def test_sigterm_from_the_first_instant_is_one_line_and_exit_143(folder, module):
    """SIGTERM as soon as the start-up guard is in (``corr_cad._startup`` loaded), while
    numpy and scipy load, and once the command line's module is in: the line and the
    status of a run interrupted later. The signal goes out on an event, the
    ``-X importtime`` line of ``module``."""
    (folder / "s.toml").write_text(DESIGN)
    p = subprocess.Popen(
        [sys.executable, "-X", "importtime", "-m", "corr_cad", "run", "s.toml", "--out", "out"],
        cwd=folder,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    seen = []
    try:
        for line in p.stderr:
            seen.append(line)
            if line.rstrip().split("|")[-1].strip() == module:
                p.send_signal(signal.SIGTERM)
                break
        seen.append(p.stderr.read())
        p.wait(timeout=HANG_S)
    finally:
        p.kill()
    lines = [ln for ln in "".join(seen).splitlines() if not ln.startswith("import time:")]
    assert p.returncode == 143, lines
    assert lines == ["corr-cad: interrupted (SIGTERM); previous outputs left as they were"]
    assert sorted(x.name for x in folder.iterdir()) == ["notes.txt", "s.toml"]


#: Runs the CLI's ``main`` with a garbage-collector callback that sends SIGINT
#: to its own process once the run holds its lock: the handler runs inside the
#: callback, and Python drops the KeyboardInterrupt it raises there.
GC_INTERRUPT = """
import gc, os, signal, sys
from corr_cad.run.cli import main
fired = []
def callback(phase, info):
    if not fired and phase == "start" and os.path.exists("out/.corr-cad.lock"):
        fired.append(1)
        os.kill(os.getpid(), signal.SIGINT)
        total = 0
        for i in range(1000):  # the handler runs here, inside the callback
            total += i
gc.callbacks.append(callback)
sys.exit(main(["run", "s.toml", "--out", "out"]))
"""


def test_an_interrupt_swallowed_in_a_gc_callback_still_ends_the_run(folder):
    (folder / "s.toml").write_text(DESIGN)
    (folder / "gc_interrupt.py").write_text(GC_INTERRUPT)
    r = subprocess.run(
        [sys.executable, "gc_interrupt.py"],
        capture_output=True,
        text=True,
        cwd=folder,
        timeout=HANG_S,
    )
    assert r.returncode == 130, r.stderr[-3000:]
    assert "Exception ignored" not in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.strip().splitlines() == [
        "corr-cad: interrupted (SIGINT); previous outputs left as they were"
    ]
    assert not (folder / "out").exists()


def test_a_closed_stdout_does_not_stop_the_run(folder):
    """``corr-cad run ... | head -1``: the reader is gone before the first line."""
    (folder / "s.toml").write_text(DESIGN)
    read_end, write_end = os.pipe()
    os.close(read_end)  # every write to stdout meets a closed pipe
    try:
        r = subprocess.run(
            [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out"],
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
            cwd=folder,
            timeout=HANG_S,
        )
    finally:
        os.close(write_end)
    assert r.returncode == 0, r.stderr[-3000:]
    assert without_progress(r.stderr) == ""  # a busy machine adds heartbeat lines
    assert (folder / "out" / "manifest.json").is_file()
    assert (folder / "out" / "inner_gear.dxf").is_file()


@pytest.mark.parametrize(
    "address,says",
    [
        ("tcp://[::1", "Invalid IPv6 URL"),
        ("tcp://[zz]:1", "not an address"),
        ("tcp://" + "h" * 300 + ":8786", "a host name of 300 characters; at most 253"),
        ("tcp://host:99999", "Port out of range"),
        ("tcp://a\x01b:1", "control characters"),
    ],
)
def test_a_malformed_scheduler_address_is_one_line(folder, address, says):
    r = cli(folder, DESIGN, "--executor", "dask", "--scheduler", address)
    line = refused(folder, r)
    assert line.startswith("corr-cad: error: --scheduler ") and says in line, line
    assert "e.g. tcp://127.0.0.1:8786" in line


# --- scene values ----------------------------------------------------------------------------


def test_an_integer_of_5000_digits_is_one_line(folder):
    line = refused(folder, cli(folder, DESIGN.replace("= 8", "= " + "9" * 5000)))
    assert "'s.toml' line 3: 'tooth_count' is a number of 5000 digits" in line
    assert "e.g. tooth_count = 39" in line


@pytest.mark.slow
def test_a_whole_number_written_as_a_float_is_that_integer(folder):
    """``tooth_count = 25.0`` is the whole number 25: the same files as ``tooth_count = 25``."""
    scene = DESIGN.replace("tooth_count = 8", "tooth_count = 25").replace("40.0", "135.0")
    scene += '[export]\nformats = ["dxf"]\n'
    a = cli(folder, scene)
    assert a.returncode == 0, a.stderr
    (folder / "out").rename(folder / "as_int")
    b = cli(folder, scene.replace("tooth_count = 25", "tooth_count = 25.0"))
    assert b.returncode == 0, b.stderr
    for name in ("inner_gear.dxf", "disk_cam.dxf"):
        assert (folder / "out" / name).read_bytes() == (folder / "as_int" / name).read_bytes()
    line = refused(folder, cli(folder, scene.replace("= 25", "= 25.5")), "as_int", "out")
    assert "[design] tooth_count = 25.5: must be an integer, e.g. " in line


@pytest.mark.parametrize(
    "scene,says",
    [
        (DESIGN + "[modification]\nequidistant_mm = 3.99\n", "allowed range is (-1, 1], e.g. 0.01"),
        (DESIGN + "[budget]\nmemory_gb = 0\n", "allowed range is (0, 1024], e.g. 3"),
    ],
)
def test_a_range_refusal_gives_a_value_that_works(folder, scene, says):
    line = refused(folder, cli(folder, scene))
    assert line.endswith(says), line


@pytest.mark.parametrize(
    "flag,value,works",
    [
        ("--max-memory", "0", "--max-memory 3"),
        ("--max-output", "1e9", "--max-output 1"),
        ("--warn-time", "-1", "--warn-time 60"),
        ("--dask-stall-timeout", "0", "--dask-stall-timeout 120"),
        ("--workers", "0", "--workers "),
    ],
)
def test_a_flag_out_of_range_gives_a_value_that_works(folder, flag, value, works):
    line = refused(folder, cli(folder, DESIGN, flag, value))
    assert f"{flag} {float(value):g}" in line or f"{flag} {value}" in line
    assert f"e.g. {works}" in line, line


@pytest.mark.slow
def test_a_budget_too_small_for_every_key_names_the_budget_that_holds_the_run(folder):
    line = refused(folder, cli(folder, DESIGN, "--max-memory", "0.01"))
    need = float(re.search(r"would need about (\S+) MB", line).group(1))
    gb = float(re.search(r"raise it: --max-memory (\S+) \(or \[budget\] memory_gb = \1\)", line)[1])
    assert need / 1024 < gb <= 1.2 * need / 1024 + 0.01, line
    # and the value it gives holds the run
    r = cli(folder, DESIGN, "--max-memory", f"{gb:g}")
    assert r.returncode == 0, r.stderr


def test_a_large_measured_dxf_blames_the_measured_profile(folder):
    """Its memory comes from reading the file: no other key (never one the scene did not set)."""
    (folder / "ring.dxf").write_bytes(b"0\nSECTION\n" + b" " * 20_000_000)
    scene = (
        DESIGN
        + '[export]\nformats = ["dxf", "datasheet"]\n[load]\ninput_torque = 1e5\n'
        + '[errors]\nmeasured_profile = "ring.dxf"\n'
    )
    line = refused(folder, cli(folder, scene, "--max-memory", "0.5"), "ring.dxf")
    assert line.startswith("corr-cad: error: [errors] measured_profile = 'ring.dxf' (19.1 MB): ")
    assert "(at measured_profile)" in line and "a file of fewer points" in line
    assert "[datasheet]" not in line and "--max-memory 1.1" in line


SHEET = DESIGN + '[export]\nformats = ["datasheet"]\n[datasheet]\n'


@pytest.mark.parametrize(
    "scene,says",
    [
        (
            SHEET + "rated_torque_Nm = 1e-310\n",
            "[datasheet] rated_torque_Nm = 1e-310: allowed range is [0.001, 1e+09], e.g. 2860",
        ),
        (
            SHEET + "rated_torque_Nm = 1.0\ntransmission_error_torque_band = 1e-310\n",
            "[datasheet] transmission_error_torque_band = 1e-310: allowed range is [0.001, 1), "
            "e.g. 0.03",
        ),
        (
            SHEET + "rated_torque_Nm = 1.0\nlost_motion_band = 5e-324\n",
            "[datasheet] lost_motion_band = 4.94066e-324: allowed range is [0.001, 1), e.g. 0.03",
        ),
        (
            SHEET + "rated_torque_Nm = 1.0\nrigidity_range = [0.5, 0.5000000000000001]\n",
            "T_2 - T_1 >= 0.001, e.g. [0.5, 1.0]",
        ),
        (
            DESIGN + '[export]\nformats = ["datasheet"]\n[load]\ninput_torque = 1e-310\n',
            "[load] input_torque = 1e-310: the datasheet's rated torque (z + 1) * input_torque "
            "would be below 0.001 N*m; set [datasheet] rated_torque_Nm (N*m, e.g. 2860)",
        ),
    ],
)
def test_inputs_that_would_put_nan_or_inf_in_datasheet_json_are_refused(folder, scene, says):
    line = refused(folder, cli(folder, scene))
    assert says in line, line


def _strict_json(path: Path):
    import json

    def refuse(name):
        raise AssertionError(f"{path.name} holds {name}")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_the_smallest_datasheet_inputs_allowed_give_finite_figures(folder):
    """Each limit itself runs, and ``datasheet.json`` holds no NaN or inf."""
    scene = (
        SHEET + "rated_torque_Nm = 0.001\nlost_motion_band = 0.001\n"
        "transmission_error_torque_band = 0.001\nrigidity_range = [0.0, 0.001]\n"
    )
    r = cli(folder, scene, "--quiet")
    assert r.returncode == 0, r.stderr
    sheet = _strict_json(folder / "out" / "datasheet.json")
    assert sheet["torsional_rigidity_Nm_per_arcmin"]["catalogue"] > 0
    _strict_json(folder / "out" / "manifest.json")


def _ring_csv(path: Path, outlier: str | None = None, at=(500,)) -> None:
    """The design's working profile as CMM points ``x,y``, with ``outlier`` rows inserted."""
    from corr_cad.geometry.design import GearDesign
    from corr_cad.geometry.profile import working_profile

    d = GearDesign(
        tooth_count=8, cam_radius=40.0, roller_radius=4.0, roller_length=6.0, eccentricity=1.5
    )
    rows = ["x,y"]
    for i, (x, y) in enumerate(working_profile(d).sample(2000)):
        rows.append(f"{float(x)!r},{float(y)!r}")
        if outlier is not None and i in at:
            rows.append(outlier)
    path.write_text("\n".join(rows) + "\n")


@pytest.mark.parametrize(
    "outlier", ["1e154,1e154", "1e154,40.0", "40.0,-1e200", "1e308,1e308", "-1.7e308,1e308"]
)
def test_measured_points_with_huge_outliers_are_one_line(folder, outlier):
    _ring_csv(folder / "cmm.csv", outlier)
    scene = DESIGN + '[export]\nformats = ["dxf"]\n[errors]\nmeasured_profile = "cmm.csv"\n'
    line = refused(folder, cli(folder, scene), "cmm.csv")
    assert "'cmm.csv': 1 point far off the ring, e.g. (" in line
    assert "more than 2 times the median radius" in line and "remove such outliers" in line


# --- file content in error lines -------------------------------------------------------------


def _table_scene(name: str) -> str:
    return DESIGN + f'[modification]\nnormal_table = "{name}"\n'


def test_a_normal_table_line_is_quoted_at_most_40_characters(folder):
    (folder / "t.csv").write_text("psi_deg,normal_mm\n0,0\n" + "SECRET" * 50 + ",1\n")
    line = refused(folder, cli(folder, _table_scene("t.csv")), "t.csv")
    quoted = re.search(r"line 3: '([^']*)' is not two numbers", line).group(1)
    assert len(quoted) <= 40 and line.count("SECRET") <= 7, line


@pytest.mark.parametrize(
    "content",
    [b"psi_deg,normal_mm\n0,0\nPATH=/usr/bin\x00API_TOKEN=sk-live-abc\n", b"\x01\x02,3\n"],
)
def test_a_normal_table_with_control_characters_is_never_quoted(folder, content):
    (folder / "t.csv").write_bytes(content)
    line = refused(folder, cli(folder, _table_scene("t.csv")), "t.csv")
    assert "holds control or NUL characters, not a text table" in line
    assert "API_TOKEN" not in line and "PATH" not in line and "\\x" not in line


def test_a_normal_table_pointed_at_the_environment_prints_none_of_it(folder, monkeypatch):
    environ = Path("/proc/self/environ")
    if not environ.is_file():
        pytest.skip("no /proc/self/environ here")
    monkeypatch.setenv("API_TOKEN", "sk-live-xyz")  # the run inherits it
    r = cli(folder, _table_scene(str(environ)))
    line = refused(folder, r)
    assert "sk-live" not in r.stderr and "API_TOKEN" not in r.stderr, line


# --- sections without effect, and a section given twice -------------------------------------

SILENT = (
    DESIGN
    + '[modification]\ninspect_against = "conjugate"\n'
    + "[assembly]\ntarget_backlash_arcmin = 2.0\n"
    + "[modification.design]\nsteps = 3\n"
    + "[dask]\nconnect_timeout_s = 3.0\n"
)


def test_silent_sections_warn_like_every_other_section_without_effect(folder):
    r = cli(folder, SILENT, "--quiet")
    assert r.returncode == 0, r.stderr
    assert warnings_of(r) == [
        "corr-cad: warning: [modification.design] has no effect in this scene: "
        'formats does not list "modification"',
        "corr-cad: warning: [modification] inspect_against has no effect in this scene: "
        'formats does not list "inspection"',
        "corr-cad: warning: [assembly] target_backlash_arcmin has no effect in this scene: "
        "[assembly] roller_classes_um is not set",
        "corr-cad: warning: [dask] connect_timeout_s has no effect in this run: "
        "--executor is process, not dask",
    ]


@pytest.mark.parametrize(
    "data",
    [
        # each key where it acts: no warning about it
        {
            "export": {"formats": ["datasheet"]},
            "load": {"input_torque": 1e5},
            "assembly": {"roller_classes_um": [0.0, 2.0], "target_backlash_arcmin": 2.0},
        },
        {"modification": {"equidistant_mm": 0.01}},
    ],
)
def test_no_warning_where_the_section_acts(data):
    from corr_cad.run.scene.scene import parse_scene

    design = {k: v for k, v in (ln.split(" = ") for ln in DESIGN.strip().splitlines()[1:])}
    data = {"design": {k: float(v) if "." in v else int(v) for k, v in design.items()}, **data}
    assert parse_scene(data).warnings == ()


def test_the_template_writes_no_section_that_would_warn():
    """``corr-cad new`` comments out what its formats leave without effect."""
    import tomllib

    from corr_cad.run.scene.scene import parse_scene, template_text

    data = tomllib.loads(template_text())
    assert "design" not in data.get("modification", {})
    assert "target_backlash_arcmin" not in data.get("assembly", {})
    assert parse_scene(data).warnings == ()


@pytest.mark.parametrize(
    "twice",
    [
        '["modification.design"]\nsteps = 3\n[modification.design]\nsteps = 5\n',
        '["modification.design"]\nsteps = 3\n[modification]\ndesign = { steps = 5 }\n',
    ],
)
def test_a_quoted_modification_design_beside_the_nested_one_is_refused(folder, twice):
    line = refused(folder, cli(folder, DESIGN + twice))
    assert "[modification.design] is given twice" in line and "keep one of them" in line


# --- the lock file ---------------------------------------------------------------------------


def _lock_case(folder: Path, kind: str) -> Path:
    out = folder / "out"
    out.mkdir()
    lock = out / ".corr-cad.lock"
    if kind == "hard link":
        (folder / "notes.txt").write_text("")  # an empty file of the user's, linked
        os.link(folder / "notes.txt", lock)
    elif kind == "empty":
        lock.write_bytes(b"")
    elif kind == "other":
        lock.write_bytes(b"corr-cad lock\nand more\n")
    return lock


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["hard link", "empty", "other"])
def test_a_lock_path_holding_a_file_corr_cad_did_not_write_is_refused_and_left(folder, kind):
    lock = _lock_case(folder, kind)
    before = lock.read_bytes()
    r = cli(folder, DESIGN)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines() == [
        ln for ln in r.stderr.strip().splitlines() if ln.startswith("corr-cad: error: ")
    ]
    line = r.stderr.strip()
    assert (
        f"{lock}: is not corr-cad's lock file" in line and "neither writes into nor removes" in line
    )
    assert lock.read_bytes() == before  # not written into ...
    assert sorted(p.name for p in (folder / "out").iterdir()) == [
        ".corr-cad.lock"
    ]  # ... nor removed
    if kind == "hard link":
        assert os.path.samefile(lock, folder / "notes.txt")
        assert (folder / "notes.txt").read_text() == ""


def test_a_lock_left_by_a_killed_run_is_taken_over_and_removed(folder):
    out = folder / "out"
    out.mkdir()
    (out / ".corr-cad.lock").write_bytes(b"corr-cad lock\n")  # a run killed by SIGKILL
    r = cli(folder, DESIGN, "--quiet")
    assert r.returncode == 0, r.stderr
    assert not (out / ".corr-cad.lock").exists() and (out / "manifest.json").is_file()


# --- a DXF tolerance the modified curve cannot meet ------------------------------------------


def _swinging_table(path: Path) -> None:
    """A normal table that swings +-0.9 mm every 2 deg of psi: far sharper than 0.001 mm allows."""
    rows = ["psi_deg,normal_mm"]
    for p in range(0, 181, 2):
        rows.append(f"{p},{(0.9 if (p // 2) % 2 else -0.9) if 0 < p < 180 else 0.0}")
    path.write_text("\n".join(rows) + "\n")


def test_a_modified_curve_beyond_the_vertex_budget_is_refused_when_the_scene_loads(folder):
    """z = 100: the modified curve's bends need more vertices than the budget, known at load."""
    _swinging_table(folder / "swing.csv")
    scene = (
        DESIGN.replace("tooth_count = 8", "tooth_count = 100").replace("40.0", "400.0")
        + '[export]\nformats = ["dxf"]\n[modification]\nnormal_table = "swing.csv"\n'
    )
    line = refused(folder, cli(folder, scene), "swing.csv")
    assert line.startswith(
        "corr-cad: error: [export] tolerance = 0.001: too fine for this design: a polyline DXF "
        "profile (the modified one) would need more than 200000 vertices"
    )


@pytest.mark.slow
def test_a_modified_curve_the_approximation_cannot_follow_writes_nothing(folder):
    """z = 8: the swinging table is measured at load (the modified ring approximated once):
    refused up front with a tolerance that works, nothing written."""
    _swinging_table(folder / "swing.csv")
    scene = DESIGN + '[export]\nformats = ["dxf"]\n[modification]\nnormal_table = "swing.csv"\n'
    line = refused(folder, cli(folder, scene, "--quiet"), "swing.csv")
    assert line.startswith("corr-cad: error: [export] tolerance = 0.001: too fine for this design")
    assert "would work" in line


def test_the_stage_s_own_refusal_of_a_curve_it_cannot_follow_says_nothing_was_written():
    """The approximation's own check, behind the load-time estimate: one line naming the
    table, the measured deviation and a way out."""
    from types import SimpleNamespace

    from corr_cad.errors import SceneError
    from corr_cad.run.stages.stages_profile import _refuse_modified

    scene = SimpleNamespace(
        tolerance=0.001,
        modification=SimpleNamespace(normal_table=SimpleNamespace(source="swing.csv")),
    )
    approx = SimpleNamespace(max_deviation=0.507, representation="polyline", entity_vertex_count=9)
    with pytest.raises(SceneError) as e:
        _refuse_modified(scene, approx)
    msg = str(e.value)
    assert msg.startswith("[export] tolerance = 0.001: the modified working profile cannot be")
    assert "swing.csv" in msg and "0.507 mm" in msg and msg.endswith("nothing was written")


@pytest.mark.parametrize("kind", ["symlink", "folder"])
def test_a_symlink_or_a_folder_at_the_lock_path_is_refused_and_left(folder, kind):
    out = folder / "out"
    out.mkdir()
    lock = out / ".corr-cad.lock"
    if kind == "symlink":
        lock.symlink_to(folder / "notes.txt")
    else:
        lock.mkdir()
    r = cli(folder, DESIGN)
    assert r.returncode == 2, r.stderr
    line = r.stderr.strip()
    assert line == line.splitlines()[0] and f"{lock}: is not corr-cad's lock file" in line
    assert lock.is_symlink() if kind == "symlink" else lock.is_dir()
    assert (folder / "notes.txt").read_text() == "mine\n"
