import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))


import pytest  # noqa: E402


@pytest.fixture
def rig():
    """In-process ROS rig (test/ros_rig.py): nodes under test + a probe, one executor."""
    pytest.importorskip('rclpy')
    from ros_rig import Rig
    r = Rig()
    yield r
    r.close()
