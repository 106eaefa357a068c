"""``corr-cad size FILE``: a scene file read for its ``[sizing]`` design search alone."""

from __future__ import annotations

import tomllib
from pathlib import Path

from corr_cad.errors import SceneError
from corr_cad.run.scene.scene import Scene, load_scene, parse_scene

__all__ = ["load_sizing_scene"]


def load_sizing_scene(path: str | Path) -> Scene:
    """The scene at ``path`` with ``[export] formats = ["sizing"]`` (what ``size`` runs).

    The file is read and checked as ``corr-cad run`` reads it first; a scene
    without ``[sizing]`` is refused in one line.
    """
    path = Path(path)
    scene = load_scene(path)
    data = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
    if "sizing" not in data:
        raise SceneError(
            f"{path.name} has no [sizing] section; 'corr-cad size' runs its design search "
            "(templates/sizing.toml is an example)"
        )
    if "sizing" in scene.formats:
        return scene
    export = dict(data.get("export", {}))
    export["formats"] = ["sizing"]
    export.pop("representation", None)
    return parse_scene({**data, "export": export}, name=path.stem, base_dir=path.parent)
