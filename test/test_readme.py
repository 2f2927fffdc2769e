"""Every command of the README runs as written (the README cannot drift from the code).

Each line of each ``bash`` block is either run here — ``drill-twin`` commands in a
scratch directory with the venv on the PATH (as after ``source .venv/bin/activate``),
the colcon workspace steps in a scratch HOME with a clone of this checkout, the node
commands and the Python snippet over DDS (test_readme_ros.py) — or listed in
:data:`NOT_HERE` with the reason it cannot run on this machine.  A new README command
that is neither fails :func:`test_every_readme_command_is_run_or_explained`.
"""
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / 'README.md'
BIN = Path(sys.executable).parent

#: README lines that cannot run here, and why (prefix match)
NOT_HERE = {
    'make demo': 'the main job: run on a fresh clone before each release (see the session '
                 'note), ~2 min',
    'make test': 'this suite itself',
    'make bench': 'the speed table, ~10 min (docs/benchmarks.md)',
    'source /opt/ros/jazzy/setup.bash': 'needs ROS 2 Jazzy from apt (Ubuntu 24.04)',
    'cd ~/ws && rosdep install': 'needs rosdep and apt (Ubuntu 24.04)',
    'python3 -m venv --system-site-packages venv': 'the Ubuntu system Python with ROS from apt',
    'source venv/bin/activate && pip install': 'the Ubuntu system Python with ROS from apt',
    'ros2 launch ': 'needs ros2launch and launch_ros (not on PyPI); tried by hand against a '
                    'colcon build of ros2/launch_ros jazzy',
    'drill-twin estimate study': 'the table of docs/estimation.md, ~20 min (its errors are '
                                 'asserted by test_estimation.py)',
    'downhole_estimator ': 'run over DDS against twin_node by test_estimator_node.py',
    'drill-twin control compare': 'the figure and table of docs/control.md, ~5 min (the '
                                  "modes' physics is asserted by test_control.py)",
    'top_drive_controller ': 'every mode run over DDS against twin_node by '
                             'test_control_node.py',
    'ros2 run drill_twin twin_node --ros-args -p autostart:=false':
        'a managed start: the transitions that follow are run through the lifecycle '
        'services by test_lifecycle.py',
    'drill-twin sweep ': 'a 96-point nonlinear map, ~1 min on 2 cores; the engine is '
                         'tested on a real multi-process Dask cluster by test_sweep.py',
    'ros2 lifecycle ': 'needs the ros2 CLI (not on PyPI); the same transitions through the '
                       'lifecycle services are run by test_lifecycle.py; tried by hand '
                       'against a colcon build of ros2/ros2cli jazzy',
    'ros2 topic pub ': 'needs the ros2 CLI (not on PyPI); tried by hand against a colcon '
                       'build of ros2/ros2cli jazzy',
    'drill-twin simulate --config rig_fem --duration 600 --live':
        'ten minutes in real time for a viewer; the live view of simulate is run (short, '
        'with an independent Foxglove client) by test_live.py',
    'drill-twin scenario run connection --live': 'a scenario in real time for a viewer; '
                                                  'the live view is tested by test_live.py',
}
#: README lines run by test_readme_ros.py (nodes over DDS)
NODE_LINES = ('twin_node ', 'soft_torque_node ')


def readme_lines():
    """``(block index, line)`` of every command line of every bash block."""
    out = []
    for k, block in enumerate(re.findall(r'```bash\n(.*?)```', README.read_text(), re.S)):
        for line in block.splitlines():
            line = line.split('  #')[0].strip()
            if line and not line.startswith('#'):
                out.append((k, line))
    return out


def _kind(line):
    if any(line.startswith(p) for p in NOT_HERE):
        return 'not here'
    if line.startswith(NODE_LINES):
        return 'node'
    if line.startswith('drill-twin ') or line == 'source .venv/bin/activate':
        return 'cli'
    if line.startswith(('mkdir -p ~/ws/src', 'python3 -m colcon build', 'ros2 run ')):
        return 'colcon'
    return None


def test_every_readme_command_is_run_or_explained():
    lines = readme_lines()
    assert len(lines) >= 25
    unclassified = [line for _, line in lines if _kind(line) is None]
    assert not unclassified, unclassified


def _bash(script, cwd, env):
    return subprocess.run(['bash', '-c', script], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=600)


def cli_blocks():
    blocks = {}
    for k, line in readme_lines():
        if _kind(line) == 'cli' and line.startswith('drill-twin '):
            blocks.setdefault(k, []).append(line)
    return list(blocks.values())


@pytest.mark.parametrize('commands', cli_blocks(), ids=lambda b: b[0][:40])
def test_readme_commands_run(commands, tmp_path):
    """A block's commands in order, in one directory (later ones use earlier outputs), with
    ``drill-twin`` found on the PATH as after ``source .venv/bin/activate``."""
    env = dict(os.environ, PATH=f'{BIN}{os.pathsep}{os.environ["PATH"]}')
    for command in commands:
        proc = _bash(command, tmp_path, env)
        assert proc.returncode == 0, (command, proc.stderr)
        assert proc.stdout.strip(), command
        assert 'Traceback' not in proc.stderr


def test_activating_the_venv_puts_the_commands_on_the_path():
    proc = _bash('source .venv/bin/activate && command -v drill-twin twin_node '
                 'soft_torque_node mcap_recorder', ROOT, dict(os.environ))
    assert proc.returncode == 0, proc.stderr
    assert len(proc.stdout.split()) == 4


def _overlay_working_tree(clone: Path):
    """Copy the checkout's uncommitted changes into the clone (a developer's suite tests the
    sources they are editing, not only the last commit)."""
    import shutil
    listed = subprocess.run(['git', 'ls-files', '-m', '-o', '--exclude-standard'], cwd=ROOT,
                            capture_output=True, text=True, check=True).stdout.split()
    for name in listed:
        if (ROOT / name).is_file():
            (clone / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, clone / name)


@pytest.mark.slow
def test_readme_colcon_workspace(tmp_path):
    """The colcon steps as written, in a scratch HOME: clone this checkout, ``python3 -m
    colcon build --symlink-install``, ``source install/setup.bash``, and ``ros2 run`` (a
    stand-in of ros2cli's ``run`` verb: the executable ``lib/<package>/<name>`` of the
    package's prefix in the ament index, run with the arguments)."""
    pytest.importorskip('colcon_core')
    lines = [line for _, line in readme_lines() if _kind(line) == 'colcon']
    assert [line.split()[0] for line in lines] == ['mkdir', 'python3', 'ros2']
    ros2_run = ('ros2() { [ "$1" = run ] || return 2; local pkg=$2 exe=$3; shift 3; '
                'local prefix; for prefix in ${AMENT_PREFIX_PATH//:/ }; do '
                'if [ -x "$prefix/lib/$pkg/$exe" ]; then "$prefix/lib/$pkg/$exe" "$@"; '
                'return $?; fi; done; echo "no executable $exe in $pkg" >&2; return 1; }')
    clone = lines[0].replace('<this repository>', str(ROOT))
    env = dict(os.environ, HOME=str(tmp_path), PATH=f'{BIN}{os.pathsep}{os.environ["PATH"]}')
    proc = _bash(clone, tmp_path, env)
    assert proc.returncode == 0, proc.stderr
    _overlay_working_tree(tmp_path / 'ws' / 'src' / 'drill_twin')
    script = '\n'.join(['set -e', ros2_run, 'cd ~/ws', *lines[1:]])
    proc = _bash(script, tmp_path, env)
    assert proc.returncode == 0, (proc.stdout[-3000:], proc.stderr[-3000:])
    summary = proc.stdout.strip().splitlines()[-1]
    assert '"model": "fem_58"' in summary
    lib = tmp_path / 'ws' / 'install' / 'drill_twin' / 'lib' / 'drill_twin'
    assert {p.name for p in lib.iterdir()} >= {'twin_node', 'soft_torque_node',
                                               'mcap_recorder', 'drill-twin'}
    # --symlink-install: the installed package is the clone's source, not a copy
    share = tmp_path / 'ws' / 'install' / 'drill_twin' / 'share' / 'drill_twin' / 'config'
    assert share.is_dir() and (share / 'benchmark_fem.yaml').resolve().is_file()
    assert shlex.split(lines[-1])[1:4] == ['run', 'drill_twin', 'drill-twin']


@pytest.mark.slow
def test_a_plain_colcon_install_ships_every_configuration_and_scenario(tmp_path):
    """``colcon build`` without ``--symlink-install`` copies the package: the installed
    share/drill_twin holds every configuration and scenario file, the installed tool finds
    them by name (before, config/operations was not installed and ``scenario list`` printed
    nothing), and it knows the revision it was built from."""
    pytest.importorskip('colcon_core')
    src = tmp_path / 'ws' / 'src'
    src.mkdir(parents=True)
    subprocess.run(['git', 'clone', '-q', str(ROOT), str(src / 'drill_twin')], check=True)
    _overlay_working_tree(src / 'drill_twin')
    env = dict(os.environ, HOME=str(tmp_path), PATH=f'{BIN}{os.pathsep}{os.environ["PATH"]}')
    script = '\n'.join(['set -e', 'cd ~/ws', 'python3 -m colcon build >/dev/null',
                        'source install/setup.bash',
                        'install/drill_twin/lib/drill_twin/drill-twin scenario list',
                        'install/drill_twin/lib/drill_twin/drill-twin config check --config '
                        'rig_fem >/dev/null',
                        'cat install/drill_twin/share/drill_twin/git_revision'])
    proc = _bash(script, tmp_path, env)
    assert proc.returncode == 0, (proc.stdout[-3000:], proc.stderr[-3000:])
    share = tmp_path / 'ws' / 'install' / 'drill_twin' / 'share' / 'drill_twin' / 'config'
    shipped = {p.name for p in (ROOT / 'config' / 'operations').glob('*.yaml')}
    assert {p.name for p in (share / 'operations').glob('*.yaml')} == shipped
    assert not (share / 'operations' / 'connection.yaml').is_symlink()
    for name in shipped:
        assert f'{name[:-5]}:' in proc.stdout
    revision = proc.stdout.strip().splitlines()[-1]
    head = subprocess.run(['git', 'rev-parse', 'HEAD'], cwd=ROOT, capture_output=True,
                          text=True, check=True).stdout.strip()
    assert revision.startswith(head)
