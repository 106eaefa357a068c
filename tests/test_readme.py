"""The README's first screen: exactly two set-up commands, the ones CI runs."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_two_setup_commands_on_the_first_screen():
    text = (ROOT / "README.md").read_text()
    block = re.search(
        r"<!-- setup-commands -->\n```bash\n(.*?)```\n<!-- /setup-commands -->", text, re.S
    )
    assert block, "setup-commands block missing"
    cmds = [line for line in block.group(1).splitlines() if line.strip()]
    assert len(cmds) == 2
    assert (
        "pip install -c constraints.txt" in cmds[0]
        and "corr-cad run templates/prototype.toml" in cmds[0]
    )
    assert cmds[1].strip() == 'python -m pytest -n auto -m "not slow"'
    assert text.index("<!-- setup-commands -->") < 1200  # first screen
    ci = (ROOT / ".ci" / "run").read_text()
    assert "setup-commands" in ci
    # CI runs the slow set after the README's quick suite: every test runs there.
    assert "python -m pytest -n auto -m slow" in ci


def _names(requirements: list[str]) -> set[str]:
    return {
        re.split(r"[<>=!~\[; ]", r, maxsplit=1)[0].lower().replace("_", "-") for r in requirements
    }


def test_constraints_pin_every_dependency():
    """The install line's lock pins each dependency and extra the project names."""
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    wanted = _names(project["dependencies"])
    for extra in ("dev", "step", "dask"):
        wanted |= _names(project["optional-dependencies"][extra])
    pins = {}
    for line in (ROOT / "constraints.txt").read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name, _, version = line.partition("==")
            pins[name.strip().lower()] = version.split(";")[0].strip()
    missing = sorted(n for n in wanted if not pins.get(n))
    assert not missing, f"not pinned in constraints.txt: {missing}"


def test_readme_formats_are_the_schemas_and_the_docs_list_their_files():
    """The README's short table names every format once; docs/outputs.md holds each file name."""
    from corr_cad.run.scene.scene_schema import FORMATS

    text = (ROOT / "README.md").read_text()
    table = text.split("## What it makes", 1)[1].split("\n\n", 2)[1]
    rows = [r.split("|")[1:3] for r in table.splitlines()[2:]]
    named = [f for cell, _ in rows for f in re.findall(r"`([\w-]+)`", cell)]
    assert sorted(named) == sorted(FORMATS), named
    outputs = (ROOT / "docs" / "outputs.md").read_text()
    files = {f for _, cell in rows for f in re.findall(r"`([^`]+)`", cell)}
    missing = sorted(f for f in files if f not in outputs)
    assert not missing, f"README names files docs/outputs.md does not: {missing}"


def test_readme_is_short():
    assert len((ROOT / "README.md").read_text().splitlines()) <= 150


def test_readme_states_the_python_the_virtualenv_and_the_step_system_libraries():
    """Python >= 3.11 as pyproject says; a virtualenv first; and the step extra's system
    libraries, which Open CASCADE's extension really links (ldd, where OCP is installed)."""
    import glob
    import os
    import shutil
    import subprocess
    import tomllib

    import pytest

    text = (ROOT / "README.md").read_text()
    start = (ROOT / "docs" / "getting-started.md").read_text()
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["requires-python"] == ">=3.11"
    for page in (text, start):
        assert "Python >= 3.11" in page or "Python 3.11 or newer" in page
        assert "python3 -m venv .venv" in page
        assert "libgl1 libx11-6" in page
    assert text.index("python3 -m venv") < text.index("<!-- setup-commands -->")  # first
    try:
        import OCP
    except ImportError:
        pytest.skip("the step extra is not installed")
    so = glob.glob(os.path.join(os.path.dirname(OCP.__file__), "OCP*.so"))
    if not so or not shutil.which("ldd"):
        pytest.skip("no OCP extension module or no ldd to read it")
    linked = subprocess.run(["ldd", so[0]], capture_output=True, text=True).stdout
    assert "libGL.so.1" in linked and "libX11.so.6" in linked
