"""The twin + external Soft-Torque loop that the two ROS nodes run, without ROS.

At every controller period the controller reads the surface torque, the twin's
stiff speed drive receives the command (zero-order hold) and the twin advances
one period.  Used to check that the topic-level loop reproduces the embedded
Soft-Torque drive of the physics model.
"""
from __future__ import annotations

import numpy as np

from ..control.soft_torque import SoftTorqueController
from .digital_twin import DigitalTwin
from .session import TickSession

__all__ = ['run_closed_loop']


def run_closed_loop(twin: DigitalTwin, controller: SoftTorqueController, rate_hz: float,
                    duration_s: float, setpoint_rad_s: float | None = None) -> dict:
    """Run the loop; returns arrays ``time``, ``bit_angular_speed``, ``bit_axial_speed``,
    ``command``, ``stuck`` (SI)."""
    setpoint = twin.surface_speed_setpoint if setpoint_rad_s is None else setpoint_rad_s
    session = TickSession(twin, rate_hz)
    dt = session.period_s
    n = int(round(duration_s * rate_hz))
    out = {k: np.empty(n) for k in ('time', 'bit_angular_speed', 'bit_axial_speed', 'command',
                                    'stuck')}
    t = twin.time_s
    m = twin.measurements()
    for i in range(n):
        cmd = controller.update(dt, setpoint, m['surface_torque_Nm'])
        session.apply('surface_speed_command', cmd)
        out['time'][i] = m['time_s']
        out['bit_angular_speed'][i] = m['bit_angular_speed_rad_s']
        out['bit_axial_speed'][i] = m['bit_axial_speed_m_s']
        out['command'][i] = cmd
        out['stuck'][i] = m['stuck']
        t += dt
        m = session.tick(t) or twin.measurements()
    return out
