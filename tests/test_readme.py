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
    assert "pip install" in cmds[0] and "corr-cad run templates/prototype.toml" in cmds[0]
    assert cmds[1].strip() == "python -m pytest -n auto"
    assert text.index("<!-- setup-commands -->") < 1200  # first screen
    ci = (ROOT / ".ci" / "run").read_text()
    assert "setup-commands" in ci
