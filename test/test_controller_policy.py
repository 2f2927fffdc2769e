"""The top-drive controller's policy without ROS (drill_twin.runtime.controller): its input
gates, its fallback, its status.  The DDS test beside a running twin is in
test_control_node.py."""
import math

import pytest

from drill_twin.control.external import external_controller, mode_drive
from drill_twin.runtime.controller import ChannelGate, ControllerSupervisor
from drill_twin.runtime.health import OK, WARN

GLITCHES = (1e30, -1e30, 1e7, -1e7, math.nan, math.inf, -math.inf)


def test_channel_gate_refuses_what_no_sensor_reports_and_holds_the_last_value():
    gate = ChannelGate('torque', -2e5, 2e5, 'N·m', max_jump=5e4)
    assert gate.offer(5000.0) is None and gate.latest == 5000.0
    for bad, words in ((math.nan, 'not finite'), (math.inf, 'not finite'),
                       (1e30, 'outside'), (-3e5, 'outside'), ('12', 'not a number'),
                       (True, 'not a number'), (None, 'not a number')):
        assert words in gate.offer(bad)
        assert gate.latest == 5000.0
    assert gate.refused == 7


def test_a_jump_is_taken_only_when_the_next_sample_confirms_it():
    gate = ChannelGate('torque', -2e5, 2e5, 'N·m', max_jump=5e4)
    gate.offer(5000.0)
    assert 'jumped' in gate.offer(1.5e5)             # a lone spike within the range
    assert gate.offer(6000.0) is None and gate.latest == 6000.0
    assert 'jumped' in gate.offer(1.2e5)             # a real step of the level ...
    assert gate.offer(1.21e5) is None and gate.latest == 1.21e5   # ... confirmed next sample
    assert gate.refused == 2


@pytest.fixture
def supervisor():
    drive = mode_drive('soft_torque', 'rig_fem')
    ctrl = external_controller(drive, max_speed_rad_s=40.0, max_accel_rad_s2=20.0,
                               torque_filter_s=1000.0)
    return ControllerSupervisor(ctrl, setpoint_rad_s=12.57, measurement_timeout_s=0.5)


def _run(sup, seconds, t0, torque=lambda t: 5000.0 + 500.0 * math.sin(3.0 * t),
         glitch_at=(), glitch=None, rate=100.0):
    """Drive the supervisor at ``rate`` for ``seconds``; returns the commands and the time."""
    commands, t = [], t0
    for k in range(int(seconds * rate)):
        t = t0 + k / rate
        value = glitch if k in glitch_at else torque(t)
        sup.on_torque(value, t)
        commands.append(sup.command(1.0 / rate, t)[0])
    return commands, t


def test_until_an_operator_set_point_the_configured_one_is_tracked(supervisor):
    commands, t = _run(supervisor, 5.0, 0.0)
    assert abs(sum(commands[-100:]) / 100 - 12.57) < 0.05 * 12.57
    level, message = supervisor.status(t)
    assert level == OK and 'configured set-point 12.57' in message
    assert supervisor.on_setpoint(10.0, t) is None
    assert 'operator set-point 10' in supervisor.status(t)[1]


@pytest.mark.parametrize('glitch', GLITCHES)
@pytest.mark.parametrize('burst', [1, 20])
def test_a_glitch_neither_moves_the_command_nor_poisons_the_state(supervisor, glitch, burst):
    """One sample, or 20 in a row (0.2 s), of ±1e30, ±1e7, NaN or ±inf N·m on the torque:
    refused and counted, the status WARNs, the command stays within 10 % of the set-point
    throughout and after (before the gate, one 1e30 sample pinned it at 40 rad/s)."""
    supervisor.on_setpoint(10.0, 0.0)
    _run(supervisor, 20.0, 0.0)                       # settled on the oscillating torque
    commands, t = _run(supervisor, 30.0, 20.0, glitch_at=range(500, 500 + burst),
                       glitch=glitch)
    assert max(abs(c - 10.0) for c in commands) < 0.1 * 10.0
    assert supervisor.torque.refused == burst
    level, message = supervisor.status(20.0 + 5.0 + burst / 100.0)
    assert level == WARN and 'refused' in message
    assert supervisor.status(t + 11.0)[0] == OK      # the window forgets it


@pytest.mark.parametrize('value', GLITCHES[:4] + (math.nan, -1.0, 'fast'))
def test_a_bad_set_point_is_refused_and_the_last_one_kept(supervisor, value):
    supervisor.on_setpoint(10.0, 0.0)
    assert 'keeping 10' in supervisor.on_setpoint(value, 1.0)
    assert supervisor.setpoint == 10.0 and supervisor.rejected_setpoints == 1
    assert supervisor.status(1.0)[0] == WARN


def test_a_command_held_at_a_speed_bound_is_a_warning(supervisor):
    supervisor.on_setpoint(1.0, 0.0)
    _run(supervisor, 5.0, 0.0)
    assert supervisor.status(5.0)[0] == OK
    # a torque step far above the steady one slows the virtual drive until its spring takes
    # the load: the command reaches 0 on the way
    t = 5.0
    while supervisor.command_rad_s > 0.0 and t < 25.0:
        t += 0.01
        supervisor.on_torque(1.5e5, t)
        supervisor.command(0.01, t)
    assert supervisor.command_rad_s == 0.0 and supervisor.saturated
    level, message = supervisor.status(t)
    assert level == WARN and 'speed limit' in message


def test_silent_torque_holds_the_set_point_and_warns(supervisor):
    supervisor.on_setpoint(10.0, 0.0)
    _run(supervisor, 2.0, 0.0)
    command, note = supervisor.command(0.01, 3.0)         # 1 s without a sample
    assert command == 10.0 and 'not arriving' in note and supervisor.fallbacks == 1
    assert supervisor.status(3.0) == (WARN, 'surface torque stopped: holding the set-point')
    supervisor.on_torque(5000.0, 3.01)
    assert 'resumes' in supervisor.command(0.01, 3.01)[1]
