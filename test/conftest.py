"""Session set-up shared by the suite.

* One ROS domain per session — per worker process under ``pytest -n`` — reserved through
  ``domain_coordinator`` (a port lock per domain id, 1-100), with DDS discovery kept on
  this host: no other process on the machine (a twin on the default domain holding a
  latched set-point, another test session) can reach the tests, and subprocesses inherit
  the domain.
* numba's kernels are loaded once before the first test — compiled first, with a notice
  and a count on the terminal, when the cache is cold (a new machine, a new version of the
  physics sources) — by the controlling process, so that parallel workers and the
  processes the tests start load them from the cache instead of compiling them again.
* Tiers (``-m``): every test is ``unit`` (numerics, in this process, fast: ``make
  test-fast``) unless it is ``ros`` (nodes in this process), ``process`` (starts
  processes: nodes over DDS, the command line, clusters) or ``slow`` (studies, long runs,
  marked in the test files).  ``ros`` and ``process`` are found from the test's source and
  its fixtures', so a new test lands in the right tier without a decorator.
"""
import inspect
import os
import random
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


import pytest  # noqa: E402

#: a test (or one of its fixtures) that mentions these runs ROS nodes in this process
_ROS = re.compile(r'\brclpy\b|\brig\b|Node\(|ros_rig')
#: ... or starts processes
_PROCESS = re.compile(r'\bsubprocess\b|\bPopen\b|_bash\(|dask_cluster|quick_gallery')


def pytest_sessionstart(session):
    """Load (or compile, saying so) the kernels once, in the controlling process."""
    if os.environ.get('PYTEST_XDIST_WORKER') or session.config.option.collectonly:
        return
    reporter = session.config.pluginmanager.get_plugin('terminalreporter')

    def say(line):
        if reporter is not None:
            reporter.write_line(f'drill_twin: {line}')
    from drill_twin.console import prepare_kernels
    prepare_kernels(say=say)


def _source(obj) -> str:
    try:
        return inspect.getsource(obj)
    except (OSError, TypeError):
        return ''


def pytest_collection_modifyitems(config, items):
    for item in items:
        texts = [_source(getattr(item, 'function', None))]
        module = getattr(item, 'module', None)
        for name, obj in vars(module).items() if module is not None else ():
            # the module's own helpers that the test calls (one level)
            if inspect.isfunction(obj) and obj.__module__ == module.__name__ \
                    and not name.startswith('test_') and re.search(rf'\b{name}\(', texts[0]):
                texts.append(_source(obj))
        for defs in item._fixtureinfo.name2fixturedefs.values():
            for fixture in defs:           # the suite's own fixtures, not pytest's
                path = getattr(inspect.getmodule(fixture.func), '__file__', '') or ''
                if Path(path).resolve().parent == HERE and fixture.argname != 'rig':
                    texts.append(_source(fixture.func))
        text = '\n'.join(texts)
        if 'rig' in item.fixturenames or _ROS.search(text):
            item.add_marker(pytest.mark.ros)
        if _PROCESS.search(text):
            item.add_marker(pytest.mark.process)
        if not any(item.get_closest_marker(m)
                   for m in ('ros', 'process', 'slow', 'bench', 'inputs')):
            item.add_marker(pytest.mark.unit)


@pytest.fixture(scope='session', autouse=True)
def ros_domain():
    """The session's reserved ROS_DOMAIN_ID (None when domain_coordinator is missing)."""
    try:
        from domain_coordinator import domain_id
    except ImportError:
        yield None
        return
    start = random.randrange(100)
    counter = iter(range(start, start + 1000))
    saved = {k: os.environ.get(k) for k in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE')}
    with domain_id(selector=lambda: next(counter) % 100 + 1) as domain:
        os.environ['ROS_DOMAIN_ID'] = str(domain)
        os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        yield domain
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


@pytest.fixture
def rig():
    """In-process ROS rig (test/ros_rig.py): nodes under test + a probe, one executor."""
    pytest.importorskip('rclpy')
    from ros_rig import Rig
    r = Rig()
    yield r
    r.close()
