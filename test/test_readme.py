"""Every drill-twin command of the README runs (the README cannot drift from the code)."""
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / 'README.md'


def readme_commands():
    blocks = re.findall(r'```bash\n(.*?)```', README.read_text(), re.S)
    cmds = []
    for block in blocks:
        for line in block.splitlines():
            line = line.split('  #')[0].strip()
            if line.startswith('drill-twin '):
                cmds.append(line)
    return cmds


def test_readme_has_commands():
    assert len(readme_commands()) >= 5


@pytest.mark.parametrize('command', readme_commands())
def test_readme_command_runs(command, tmp_path):
    args = shlex.split(command)[1:]
    proc = subprocess.run([sys.executable, '-m', 'drill_twin.cli', *args], cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip()
