"""The whole-drive speed benchmark's scene: the prototype with compound.toml's first stage."""

import tomllib
from pathlib import Path

from corr_cad.run.bench.bench_compound import FIRST_STAGE_SCENE
from corr_cad.run.scene.scene import parse_scene

ROOT = Path(__file__).resolve().parent.parent


def test_bench_scene_is_the_prototype_with_the_compound_first_stage_and_every_solid_format():
    scene = parse_scene(tomllib.loads(FIRST_STAGE_SCENE), "bench")
    template = tomllib.loads((ROOT / "templates" / "compound.toml").read_text())["first_stage"]
    table = tomllib.loads(FIRST_STAGE_SCENE)["first_stage"]
    assert table == template
    assert scene.first_stage is not None
    assert {"dxf", "png", "forces", "stl", "3mf", "glb", "ply", "step", "interference"} <= set(
        scene.formats
    )
    # 22 N*m at the pinion, times 90/18: the prototype's 110 N*m (1.1e5 N*mm) on the crank
    assert abs(scene.load.input_torque - 1.1e5) < 1e-6
    proto = parse_scene(tomllib.loads((ROOT / "templates" / "prototype.toml").read_text()), "p")
    assert scene.design == proto.design
    assert scene.tolerance == proto.tolerance and tuple(scene.assembly_angles_deg) == (0.0,)
