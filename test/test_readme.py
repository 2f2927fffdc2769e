"""Every drill-twin command of the README runs (the README cannot drift from the code)."""
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / 'README.md'


def readme_blocks():
    """The drill-twin commands of each bash block (a block's commands run in order, in one
    directory: later ones use the files of earlier ones)."""
    blocks = re.findall(r'```bash\n(.*?)```', README.read_text(), re.S)
    out = []
    for block in blocks:
        cmds = [line.split('  #')[0].strip() for line in block.splitlines()]
        cmds = [c for c in cmds if c.startswith('drill-twin ')]
        if cmds:
            out.append(cmds)
    return out


def test_readme_has_commands():
    assert sum(len(b) for b in readme_blocks()) >= 10


@pytest.mark.parametrize('commands', readme_blocks(), ids=lambda b: b[0][:40])
def test_readme_commands_run(commands, tmp_path):
    for command in commands:
        args = shlex.split(command)[1:]
        proc = subprocess.run([sys.executable, '-m', 'drill_twin.cli', *args], cwd=tmp_path,
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, (command, proc.stderr)
        assert proc.stdout.strip(), command
