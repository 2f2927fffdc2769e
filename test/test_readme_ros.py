"""The README's ROS section, run as written: the two node commands of its bash block and
its Python operator snippet, in separate processes over DDS (the session's domain)."""
import os
import re
import select
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip('rclpy')
README = Path(__file__).resolve().parents[1] / 'README.md'


def _ros_section():
    text = README.read_text().split('## The ROS 2 nodes', 1)[1]
    nodes = [line.strip() for block in re.findall(r'```bash\n(.*?)```', text, re.S)[:1]
             for line in block.splitlines() if line.strip().endswith('_node') or
             '_node --ros-args' in line]
    snippet = re.findall(r'```python\n(.*?)```', text, re.S)[0]
    return nodes, snippet


@pytest.mark.slow
def test_readme_nodes_and_operator_snippet(tmp_path):
    nodes, snippet = _ros_section()
    assert [n.split()[0] for n in nodes] == ['twin_node', 'soft_torque_node']
    env = dict(os.environ, PYTHONUNBUFFERED='1')  # the session's domain (conftest.py)
    bin_dir = Path(sys.executable).parent  # as after `source .venv/bin/activate`
    procs = [subprocess.Popen([str(bin_dir / shlex.split(n)[0]), *shlex.split(n)[1:]], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
             for n in nodes]
    script = tmp_path / 'operator.py'
    script.write_text(snippet)
    operator = subprocess.Popen([sys.executable, str(script)], env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
    procs.append(operator)
    lines = []
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and len(lines) < 20:
            ready, _, _ = select.select([operator.stdout], [], [], deadline - time.monotonic())
            if not ready:
                break
            line = operator.stdout.readline()
            if not line:
                break
            if line.startswith('bit:'):
                lines.append(line)
    finally:
        for p in procs:
            p.send_signal(signal.SIGINT)
        outputs = []
        for p in procs:
            try:
                outputs.append(p.communicate(timeout=20)[0])
            except subprocess.TimeoutExpired:
                p.kill()
                outputs.append(p.communicate()[0])
    assert len(lines) >= 20, outputs
    speeds = [float(line.split()[1]) for line in lines]
    assert all(0.0 <= w < 60.0 for w in speeds)
    for p, out in zip(procs[:2], outputs):
        assert p.returncode == 0, out[-2000:]
