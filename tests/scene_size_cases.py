"""The scenes whose estimates ``tests/data/estimates_golden.json`` holds.

Every template, and the shapes of scene whose sizes the structural limits and
the estimate compute: a wavy ``[modification] normal_table`` (STEP, meshes, a
spline DXF), a fine polyline DXF with the wire-EDM path, the mesh
interference, a 1000-tooth ring. Regenerate the golden file only on purpose:
``python tests/scene_size_cases.py`` (the estimate's numbers are an interface
the budget's refusals follow).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = Path(__file__).resolve().parent / "data" / "estimates_golden.json"

_WAVE = "".join(
    f"{3.0 * i:.6f},{0.01 + 0.002 * math.sin(math.radians(3.0 * i) * 30):.6f}\n" for i in range(61)
)
_MOD = '[modification]\nnormal_table = "wave.csv"\n'
_Z1000 = "[design]\ntooth_count = 1000\neccentricity = 0.05\nroller_radius = 0.3\n"

#: name -> scene text (the templates are read from templates/).
EXTRA = {
    "step wavy": '[export]\nformats = ["step", "png"]\nassembly_angles_deg = [0.0, 7.0]\n'
    "chord_tolerance = 0.002\n" + _MOD,
    "meshes wavy": '[export]\nformats = ["stl", "3mf", "glb", "ply"]\n'
    "assembly_angles_deg = [0.0, 5.0]\n" + _MOD,
    "spline dxf wavy edm": '[export]\nformats = ["dxf", "edm", "cmm"]\n'
    'representation = "spline"\ntolerance = 0.0001\n' + _MOD,
    "dxf 1e-4 edm cmm report": '[export]\nformats = ["dxf", "png", "edm", "cmm", "report"]\n'
    "tolerance = 0.0001\n",
    "interference both": '[export]\nformats = ["interference", "stl"]\n'
    'interference_method = "both"\ninterference_positions = 12\nchord_tolerance = 0.0005\n',
    "z1000 every mesh": _Z1000 + '[export]\nformats = ["dxf", "step", "stl", "interference"]\n'
    "tolerance = 0.0005\n",
}

#: name -> scene text that load_scene or check_scene refuses (the golden file holds the line).
REFUSED = {
    "dxf too fine": '[export]\nformats = ["dxf"]\ntolerance = 1e-9\n',
    "spline wavy too fine": '[export]\nformats = ["dxf"]\nrepresentation = "spline"\n'
    "tolerance = 1e-11\n" + _MOD,
    "edm too fine": '[export]\nformats = ["edm"]\ntolerance = 1e-8\n',
    "stl too fine": '[export]\nformats = ["stl"]\nchord_tolerance = 1e-7\n',
    "step wavy too fine": '[export]\nformats = ["step"]\nchord_tolerance = 1e-6\n' + _MOD,
    "meshes wavy past the output budget": '[export]\nformats = ["stl", "3mf", "glb", "ply"]\n'
    "assembly_angles_deg = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0]\n"
    "chord_tolerance = 0.00003\n" + _MOD,
    "forces past the memory budget": '[export]\nformats = ["forces"]\n[load]\n'
    "input_torque = 1.1e5\n[solver]\npositions = 1000000\n",
}

#: The executors the golden file holds each estimate for (2 workers for ``process``).
EXECUTORS = ("process", "serial")


def refusal(path: Path) -> str:
    """The one line with which the way in (load, budget, check at 2 workers) refuses ``path``."""
    from corr_cad.errors import SceneError
    from corr_cad.run.budget.resources import budget_for, check_scene
    from corr_cad.run.scene.scene import load_scene

    try:
        scene = load_scene(path)
        check_scene(scene, 2, budget_for(scene, 3.0), "process")
    except SceneError as exc:  # "or raise it: ..." names this machine's memory
        return str(exc).split(", or raise it")[0]
    return "accepted"


def scenes(folder: Path) -> dict[str, Path]:
    """Write the extra scenes (and wave.csv) into ``folder``; name -> scene path."""
    (folder / "wave.csv").write_text("psi_deg,normal_mm\n" + _WAVE)
    out = {f"template {p.stem}": p for p in sorted((ROOT / "templates").glob("*.toml"))}
    for i, (name, text) in enumerate(EXTRA.items()):
        path = folder / f"s{i}.toml"
        path.write_text(text)
        out[name] = path
    return out


def numbers(scene, workers: int = 2, executor: str = "process") -> dict:
    """The estimate's numbers, as JSON can hold them exactly (float hex)."""
    from corr_cad.run.budget.resources import estimate

    est = estimate(scene, workers, executor)
    d = est.as_dict()
    d["profile_vertices"] = est.profile_vertices
    d["mesh_triangles"] = est.mesh_triangles
    d["workers"] = est.workers

    def enc(x):
        if isinstance(x, float):
            return x.hex()
        if isinstance(x, dict):
            return {k: enc(v) for k, v in x.items()}
        return x

    return enc(d)


def main() -> None:  # pragma: no cover - run by hand
    import tempfile

    from corr_cad.run.scene.scene import load_scene

    folder = Path(tempfile.mkdtemp())
    got = {}
    for name, path in scenes(folder).items():
        scene = load_scene(path)
        got[name] = {ex: numbers(scene, 2 if ex == "process" else 1, ex) for ex in EXECUTORS}
    for i, (name, text) in enumerate(REFUSED.items()):
        path = folder / f"r{i}.toml"
        path.write_text(text)
        got["refused " + name] = refusal(path)
    GOLDEN.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":  # pragma: no cover
    main()
