"""Controller modes run over topics: the controller node's policy, without ROS.

Over topics a controller can only change the speed command of the twin's (or a rig's)
own drive.  Each mode is realised as a *virtual drive* (:class:`~drill_twin.physics.
soft_torque.SoftTorqueController`): an inertia J_m tied to the set-point by the mode's
``K_i`` and ``K_p``, loaded by the measured torque swing and tracking ``ω_set - g_T (T_s -
T_ref)``; its speed is the command.  On a drive that follows its command closely this is
the embedded mode's closed loop (docs/control.md).  ``stiff_pi`` passes the set-point
through: the drive's own loop is the stiff PI.
"""
from __future__ import annotations

from ..config.lookup import resolve_config
from ..config.scenario import load_scenario, read_config
from ..errors import ParameterError
from ..physics.top_drive import CONTROLLERS, TopDrive
from .soft_torque import SoftTorqueController

__all__ = ['CONTROLLERS', 'mode_drive', 'external_controller', 'configured_speed']


def mode_drive(mode: str, config: str, overrides=()) -> TopDrive:
    """The motor drive of ``config`` with the gains of ``mode`` (stability_tuned: tuned at
    the configuration's operating point; takes seconds)."""
    if mode not in CONTROLLERS:
        raise ParameterError(f'mode must be one of {", ".join(CONTROLLERS)}, got {mode!r}')
    if read_config(resolve_config(config)).get('units') != 'si':
        raise ParameterError(f'the top-drive controller needs an SI configuration (units: si);'
                             f' {config} is not one')
    sc = load_scenario(config, list(overrides) + ['model.top_drive=motor',
                                                  f'drive.controller={mode}'])
    return sc.model.top_drive


def configured_speed(config: str, overrides=()) -> float:
    """The surface speed of the configuration's operating point [rad/s]: what the twin built
    from the same configuration turns at until an operator set-point arrives."""
    sc = load_scenario(config, list(overrides))
    return float(sc.groups.omega_o / sc.scales.time_s)


def external_controller(drive: TopDrive, **limits) -> SoftTorqueController:
    """The virtual drive of a mode (``limits``: max_speed_rad_s, max_accel_rad_s2,
    torque_filter_s); disabled (pass-through) for ``stiff_pi``."""
    g = drive.gains
    ctrl = SoftTorqueController(drive.motor_inertia_kgm2, g.integral_Nm_rad,
                                g.proportional_Nms_rad,
                                torque_feedback=g.torque_feedback_rad_s_Nm, **limits)
    ctrl.enabled = drive.controller != 'stiff_pi'
    return ctrl
