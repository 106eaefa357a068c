"""Shop and inspection files name the profile they describe (conjugate or modified).

The ``.nc`` header, ``inner_gear_edm.dxf``, the CMM CSV's first line, the
manifest's ``edm`` and ``cmm`` blocks and ``inspection.json``'s nominal each
say which working profile they describe: conjugate, or modified with every
family and its amount. Two programs for different rings never read alike.
The EDM stage never solves forces to place its lead-in.
"""

import json
import subprocess
import sys

import ezdxf
import pytest

from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.modification import Modification, NormalTable, describe_profile
from corr_cad.run.stages.stages import plan


def _run(folder, text, name="s.toml", out="out"):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", name, "--out", out, "--quiet"],
        cwd=folder,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    return folder / out


def _header(nc_text: str) -> list[str]:
    """The comment lines before the first G-code word."""
    out = []
    for line in nc_text.splitlines():
        if line.startswith("G"):
            break
        out.append(line)
    return out


SHOP = '[export]\nformats = ["edm", "cmm"]\n[load]\ninput_torque = 1.1e5\n'


@pytest.fixture(scope="module")
def rings(tmp_path_factory):
    base = tmp_path_factory.mktemp("rings")
    return {
        "conjugate": _run(base / "c", SHOP),
        "a": _run(base / "a", SHOP + "[modification]\nequidistant_mm = 0.01\nshift_mm = 0.004\n"),
        "b": _run(base / "b", SHOP + "[modification]\nequidistant_mm = 0.011\nshift_mm = 0.004\n"),
    }


@pytest.mark.slow
def test_nc_header_names_the_profile_and_two_rings_never_read_alike(rings):
    heads = {k: _header((v / "inner_gear_edm.nc").read_text()) for k, v in rings.items()}
    conj = " ".join(heads["conjugate"])
    assert "profile: conjugate" in conj and "exact conjugate working profile" in conj
    for k in ("a", "b"):
        text = " ".join(heads[k])
        assert "profile: modified: equidistant" in text and "shift +0.004 mm" in text
        assert "exact modified working profile" in text and "conjugate" not in text
    assert "equidistant +0.01 mm" in " ".join(heads["a"])
    assert "equidistant +0.011 mm" in " ".join(heads["b"])
    assert heads["a"] != heads["b"] != heads["conjugate"]


@pytest.mark.slow
def test_edm_dxf_cmm_csv_and_manifest_name_the_profile(rings):
    for k, out in rings.items():
        doc = ezdxf.readfile(out / "inner_gear_edm.dxf")
        prop = doc.header.custom_vars.get("corr_cad.edm.profile")
        first = (out / "inner_gear_nominal.csv").read_text().splitlines()[0]
        man = json.loads((out / "manifest.json").read_text())
        assert first.startswith("# corr_cad CMM nominal points") and first.endswith(prop)
        for block in ("edm", "cmm"):
            rec = man[block]["profile"]
            assert rec["description"] == prop
            assert rec["kind"] == ("conjugate" if k == "conjugate" else "modified")
        if k != "conjugate":
            rec = man["edm"]["profile"]
            assert rec["families"] == ["equidistant", "shift"] and rec["shift_mm"] == 0.004
            assert "modified working profile" in man["edm"]["offset_side"]
    ids = {json.loads((o / "manifest.json").read_text())["edm"]["profile"]["profile_id"]
           for o in rings.values()}  # fmt: skip
    assert len(ids) == 3


def test_descriptions_of_different_rings_differ():
    d = GearDesign()
    rows = (0.0, 60.0, 120.0, 180.0)
    t1 = NormalTable(rows, (0.01, 0.008, 0.004, 0.002))
    t2 = NormalTable(rows, (0.01, 0.008, 0.0041, 0.002))  # same rows, min and max
    cases = [
        describe_profile(d, None),
        describe_profile(GearDesign(eccentricity=3.5000001), None),
        describe_profile(d, Modification(equidistant_mm=0.01)),
        describe_profile(d, Modification(equidistant_mm=0.0100000001)),
        describe_profile(d, Modification(shift_mm=0.01)),
        describe_profile(d, Modification(normal_table=t1)),
        describe_profile(d, Modification(normal_table=t2)),
    ]
    assert len(set(cases)) == len(cases)
    assert describe_profile(d, Modification()) == cases[0]  # a zero modification: conjugate
    # amounts positional, never in scientific notation
    assert "equidistant +0.00001 mm" in describe_profile(d, Modification(equidistant_mm=1e-5))


@pytest.mark.slow
def test_edm_stage_places_its_lead_in_without_a_force_solve(rings, tmp_path):
    assert "forces" not in plan(("edm",)) and "forces" not in plan(("edm", "cmm"))
    man = json.loads((rings["a"] / "manifest.json").read_text())
    assert "forces" not in [s["name"] for s in man["stages"]]
    assert man["edm"]["lead_in_point"]["psi_deg"] == 180.0  # the tooth tip, by geometry
    # with the forces format the EDM stage reuses that stage's solve (one solve in all)
    out = _run(tmp_path, SHOP.replace('"cmm"', '"forces"') + "[solver]\npositions = 90\n")
    man = json.loads((out / "manifest.json").read_text())
    assert [s["name"] for s in man["stages"]].count("forces") == 1
    assert man["edm"]["lead_in_point"]["positions"] == 90


@pytest.mark.slow
def test_inspection_names_its_nominal_and_reads_the_cmm_file_back(rings, tmp_path):
    """The modified ring's own CMM nominal file, measured: it inspects against the
    modified profile, and the reader skips the profile line."""
    (tmp_path / "cmm.csv").write_bytes((rings["a"] / "inner_gear_nominal.csv").read_bytes())
    mod = "[modification]\nequidistant_mm = 0.01\nshift_mm = 0.004\n"
    text = '[export]\nformats = ["inspection"]\n[errors]\nmeasured_profile = "cmm.csv"\n' + mod
    out = _run(tmp_path, text)
    res = json.loads((out / "inspection.json").read_text())
    assert res["nominal_profile"].startswith("modified: equidistant +0.01 mm, shift +0.004 mm")
    assert res["profile_deviation_max_mm"] < 1e-6
    out = _run(tmp_path, text + 'inspect_against = "conjugate"\n', out="out2")
    res = json.loads((out / "inspection.json").read_text())
    assert res["nominal_profile"].startswith("conjugate")
