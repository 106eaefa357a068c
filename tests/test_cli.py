"""The command line as a user runs it."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def corr_cad(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", *args], capture_output=True, text=True, cwd=cwd
    )


def test_help_lists_commands():
    r = corr_cad("--help")
    assert r.returncode == 0 and "run" in r.stdout and "new" in r.stdout


@pytest.mark.slow
def test_new_then_run(tmp_path):
    scene = tmp_path / "mine.toml"
    assert corr_cad("new", str(scene)).returncode == 0
    r = corr_cad("run", str(scene), "--out", str(tmp_path / "out"))
    assert r.returncode == 0, r.stderr
    assert "measured max deviation" in r.stdout
    assert (tmp_path / "out" / "inner_gear.dxf").exists()
    again = corr_cad("new", str(scene))
    assert again.returncode == 2 and "exists" in again.stderr


def test_default_out_dir_and_quiet(tmp_path):
    scene = tmp_path / "quiet_one.toml"
    scene.write_text('[export]\nformats = ["dxf"]\n')
    r = corr_cad("run", str(scene), "--quiet", cwd=tmp_path)
    assert r.returncode == 0 and r.stdout == "" and r.stderr == ""
    assert (tmp_path / "outputs" / "quiet_one" / "manifest.json").exists()


@pytest.mark.parametrize(
    "text,needle",
    [
        ("[design]\nroller_radius = 11.0\n", "undercut"),
        ("[design]\ncam_radius = nan\n", "cam_radius = nan"),
        ("[design\n", "not valid TOML"),
        ("[design]\nfoo = 1\n", "unknown key 'foo'"),
    ],
)
def test_errors_are_one_line_exit_2_and_write_nothing(tmp_path, text, needle):
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    out = tmp_path / "out"
    r = corr_cad("run", str(scene), "--out", str(out))
    assert r.returncode == 2
    assert needle in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


def test_undercut_message_gives_admissible_radius(tmp_path):
    scene = tmp_path / "u.toml"
    scene.write_text("[design]\nroller_radius = 11.0\n")
    r = corr_cad("run", str(scene), "--out", str(tmp_path / "o"))
    assert "largest admissible roller radius for this design is 10.053" in r.stderr


def test_allow_undercut_flags_the_range(tmp_path):
    import json

    scene = tmp_path / "u.toml"
    scene.write_text(
        '[design]\nroller_radius = 11.0\nallow_undercut = true\n[export]\nformats = ["dxf"]\n'
    )
    r = corr_cad("run", str(scene), "--out", str(tmp_path / "o"))
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert m["undercut"]["undercut"] is True
    lo, hi = m["undercut"]["psi_range_deg"]
    assert lo < 180 < hi
    assert m["profile"]["tooth_tip_trimmed"] is True
    assert m["accuracy"]["working_profile"]["max_deviation_mm"] <= 0.001


def test_missing_scene_file(tmp_path):
    r = corr_cad("run", str(tmp_path / "nope.toml"))
    assert r.returncode == 2 and "does not exist" in r.stderr


@pytest.mark.slow
def test_bundled_prototype_runs(tmp_path):
    r = corr_cad("run", str(ROOT / "templates" / "prototype.toml"), "--out", str(tmp_path / "p"))
    assert r.returncode == 0, r.stderr
    assert "roller 1: F_j mean 1741.9 N" in r.stdout


@pytest.mark.slow
def test_fresh_template_runs_without_a_warning(tmp_path):
    """`corr-cad new` then `run`: nothing in the template is a silent no-op, nor warned."""
    scene = tmp_path / "fresh.toml"
    assert corr_cad("new", str(scene)).returncode == 0
    r = corr_cad("run", str(scene), "--out", str(tmp_path / "out"), "--quiet")
    assert r.returncode == 0 and r.stderr == "", r.stderr


def test_undercut_is_refused_before_anything_runs(tmp_path):
    scene = tmp_path / "u.toml"
    scene.write_text('[design]\nroller_radius = 11.0\n[export]\nformats = ["dxf"]\n')
    r = corr_cad("run", str(scene), "--out", str(tmp_path / "out"))
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.startswith("corr-cad: error: [design] roller_radius = 11: ")
    assert "10.053" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_shop_and_interference_keys_without_their_format_warn(tmp_path):
    scene = tmp_path / "w.toml"
    scene.write_text(
        '[export]\nformats = ["dxf"]\ninterference_method = "mesh"\n'
        "[edm]\nwire_diameter = 0.3\n[inspection]\npoint_spacing = 2.0\n"
    )
    r = corr_cad("run", str(scene), "--out", str(tmp_path / "out"), "--quiet")
    assert r.returncode == 0
    warned = [ln for ln in r.stderr.splitlines() if ln.startswith("corr-cad: warning: ")]
    assert len(warned) == 3
    for what in ("[export] interference_method", "[edm]", "[inspection]"):
        assert any(what + " has no effect" in ln for ln in warned), what


@pytest.mark.slow
def test_user_files_with_corr_cad_names_are_left_alone(tmp_path):
    """A lock file or a staging-named folder that corr-cad did not make survives a run."""
    (tmp_path / ".corr-cad.lock").write_text("LOCKMINE\n")
    mine = tmp_path / ".corr-cad-staging-1-abc"
    mine.mkdir()
    (mine / "keep").write_text("mine\n")
    scene = tmp_path / "d.toml"
    scene.write_text('[export]\nformats = ["dxf"]\ntolerance = 0.01\n')
    r = corr_cad("run", str(scene), "--out", str(tmp_path), "--quiet")
    assert r.returncode == 2 and "is not corr-cad's lock file" in r.stderr
    assert (tmp_path / ".corr-cad.lock").read_text() == "LOCKMINE\n"
    (tmp_path / ".corr-cad.lock").unlink()
    r = corr_cad("run", str(scene), "--out", str(tmp_path), "--quiet")
    assert r.returncode == 0, r.stderr
    assert (mine / "keep").read_text() == "mine\n"
    assert "not a corr-cad staging folder" in r.stderr


def test_sweep_range_with_no_valid_design_is_refused(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[export]\nformats = ["sweeps"]\n[load]\ninput_torque = 1.1e5\n'
        "[sweeps]\neccentricity = [1e300, 1e301]\npoints = 2\npositions = 36\n"
    )
    r = corr_cad("run", str(scene), "--out", str(tmp_path / "o"), "--quiet")
    assert r.returncode == 2 and not (tmp_path / "o").exists()
    assert r.stderr.startswith("corr-cad: error: [sweeps] eccentricity = [1e+300, 1e+301]: ")
