"""Session set-up shared by the suite.

* One ROS domain for the whole session, reserved through ``domain_coordinator``
  (a port lock per domain id, 1-100), with DDS discovery kept on this host: no
  other process on the machine (a twin on the default domain holding a latched
  set-point, another test session) can reach the tests, and subprocesses
  inherit the domain.
* numba's kernels are compiled (or loaded) once, before the first test.
"""
import os
import random
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))


import pytest  # noqa: E402


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


@pytest.fixture(scope='session', autouse=True)
def warm_kernels():
    """Compile or load the numba kernels once per session (the first test pays, not a
    timing-sensitive ROS test)."""
    from drill_twin.physics.scenario import load_scenario
    from drill_twin.physics.simulation import Simulation
    Simulation.from_scenario(load_scenario('benchmark_fem')).warm_up()


@pytest.fixture
def rig():
    """In-process ROS rig (test/ros_rig.py): nodes under test + a probe, one executor."""
    pytest.importorskip('rclpy')
    from ros_rig import Rig
    r = Rig()
    yield r
    r.close()
