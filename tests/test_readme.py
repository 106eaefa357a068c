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
    assert cmds[1].strip() == "python -m pytest -n auto"
    assert text.index("<!-- setup-commands -->") < 1200  # first screen
    ci = (ROOT / ".ci" / "run").read_text()
    assert "setup-commands" in ci


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
