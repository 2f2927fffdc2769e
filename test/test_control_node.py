"""Each controller mode over DDS with the twin: the node runs the mode's gains (those the
physics library computes for the configuration), commands the twin, and the twin follows
it; the command obeys the mode's law (pass-through for stiff PI, the virtual drive of the
mode otherwise, replayed offline from the node's own inputs)."""
import math

import numpy as np
import pytest

rclpy = pytest.importorskip('rclpy')
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from drill_twin.control.external import mode_drive  # noqa: E402
from drill_twin.ros.soft_torque_node import TopDriveControllerNode  # noqa: E402
from drill_twin.ros.twin_node import COMMAND_QOS, TwinNode  # noqa: E402


def _diag_values(msg):
    for st in msg.status:
        if 'top_drive_controller' in st.name:
            return {kv.key: kv.value for kv in st.values}
    return None


@pytest.mark.timeout(600)
@pytest.mark.parametrize('mode', ['stiff_pi', 'soft_torque', 'z_torque', 'stability_tuned'])
def test_controller_mode_drives_the_twin_over_dds(rig, mode):
    twin = rig.add(TwinNode(context=rig.ctx, parameter_overrides=[
        Parameter('real_time_factor', value=5.0), Parameter('stability_period_s', value=0.0)]))
    ctrl = rig.add(TopDriveControllerNode(context=rig.ctx, parameter_overrides=[
        Parameter('mode', value=mode)]))
    expected = mode_drive(mode, 'rig_fem').gains
    rig.listen('surface_speed_command', Float64, lambda m: m.data, qos=COMMAND_QOS)
    rig.listen('/diagnostics', DiagnosticArray, _diag_values, qos=10)
    rig.publisher('surface_speed_setpoint').publish(Float64(data=12.57))
    assert rig.spin_until(lambda: len(rig.data['surface_speed_command']) > 100
                          and any(rig.data['/diagnostics']), 60)
    assert twin.arbiter.source == 'controller'
    diag = next(d for d in rig.data['/diagnostics'] if d)
    assert diag['mode'] == mode
    assert float(diag['proportional_gain_Nms_rad']) == pytest.approx(
        expected.proportional_Nms_rad, rel=1e-5)
    assert float(diag['torque_feedback_rad_s_Nm']) == pytest.approx(
        expected.torque_feedback_rad_s_Nm, rel=1e-5, abs=1e-12)
    cmds = np.array(rig.data['surface_speed_command'])
    assert np.all(np.isfinite(cmds)) and np.all(cmds >= 0)
    if mode == 'stiff_pi':
        assert np.all(cmds == 12.57)
    else:
        # the virtual drive answers the torque swing: the command moves, around the set-point
        assert np.ptp(cmds) > 0 and math.isclose(np.median(cmds), 12.57, rel_tol=0.05)
    assert not ctrl.in_fallback
