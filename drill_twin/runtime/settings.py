"""The run-time settings of the nodes as plain data: type, unit, range, start-up only or not.

Each node declares its ROS parameters from one of these tables
(:func:`drill_twin.ros.common.declare_settings`), so that ``ros2 param describe``
shows the unit, the range and whether the parameter is read-only (acts only at
start-up), and tests can check every entry without ROS.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

__all__ = ['Setting', 'TWIN_SETTINGS', 'CONTROLLER_SETTINGS', 'RECORDER_SETTINGS',
           'ESTIMATOR_SETTINGS', 'OPCUA_SETTINGS', 'check', 'ros_home']


@dataclass(frozen=True)
class Setting:
    """One node parameter.

    ``low``/``high`` bound a float (inclusive); ``read_only`` parameters act only at
    start-up (set them with ``--ros-args -p`` or in a launch file).
    """

    name: str
    default: object
    description: str
    unit: str = ''
    low: float | None = None
    high: float | None = None
    read_only: bool = False

    @property
    def text(self) -> str:
        unit = f' [{self.unit}]' if self.unit else ''
        when = ' (start-up only)' if self.read_only else ''
        return f'{self.description}{unit}{when}'


def check(setting: Setting, value) -> str | None:
    """Why ``value`` is not acceptable for ``setting`` (None if it is)."""
    if setting.low is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f'{setting.name} must be a number, got {value!r}'
    if not (math.isfinite(value) and setting.low <= value <= setting.high):
        unit = f' {setting.unit}' if setting.unit else ''
        return (f'{setting.name} = {value!r}{unit} outside [{setting.low:g}, '
                f'{setting.high:g}]{unit}')
    return None


TWIN_SETTINGS = (
    Setting('config', 'rig_fem', 'configuration file, or a name in '
            'share/drill_twin/config (units: si)', read_only=True),
    Setting('overrides', [''], 'configuration overrides KEY=VALUE (dotted keys)',
            read_only=True),
    Setting('scenario', '', 'operations scenario file or name in config/operations: the '
            'twin is built from it (instead of config/overrides) and runs its timeline; '
            '"" = none', read_only=True),
    Setting('real_time_factor', 1.0, 'simulated seconds per wall second', '', 0.01, 1000.0),
    Setting('publish_rate_hz', 100.0, 'measurement publish rate', 'Hz', 1.0, 2000.0),
    Setting('drive_time_constant_s', 0.0, 'speed-drive lag, 0 = stiff drive', 's', 0.0, 10.0,
            read_only=True),
    Setting('max_surface_speed_rad_s', 40.0, 'largest accepted surface-speed set-point',
            'rad/s', 0.1, 100.0),
    Setting('command_timeout_s', 0.5, 'controller commands older than this are ignored '
            '(back to the operator set-point)', 's', 0.01, 60.0),
    Setting('stability_period_s', 30.0, 'stability advisory period, 0 = off', 's', 0.0, 3600.0),
    Setting('as_fast_as_possible', False, 'run unthrottled and publish /clock',
            read_only=True),
    Setting('record_path', '', 'record the run to this .mcap file (simulated log time); '
            'none (or "") = off', read_only=True),
    Setting('record_chunk_period_s', 0.25, 'longest span one MCAP chunk holds = most a kill '
            'can lose', 's', 0.01, 10.0, read_only=True),
    Setting('autostart', True, 'configure and activate at start-up (false: wait for the '
            'lifecycle transitions, e.g. ros2 lifecycle set)', read_only=True),
    Setting('foxglove_port', 0, 'serve the live view (Foxglove WebSocket protocol) on '
            'ws://localhost:PORT (1-65535), localhost only; 0 = off', read_only=True),
)

CONTROLLER_SETTINGS = (
    Setting('config', 'rig_fem', 'string and drive configuration the gains are computed '
            'from (units: si)', read_only=True),
    Setting('mode', 'soft_torque', 'controller: soft_torque | z_torque | stability_tuned | '
            'stiff_pi (docs/control.md)', read_only=True),
    Setting('control_rate_hz', 100.0, 'command rate', 'Hz', 1.0, 5000.0),
    Setting('enabled', True, 'controller on (true) or pass the set-point through (false)'),
    Setting('max_surface_speed_rad_s', 40.0, 'command upper bound; larger set-points are '
            'rejected', 'rad/s', 0.1, 100.0),
    Setting('max_acceleration_rad_s2', 20.0, 'command rate limit', 'rad/s^2', 0.01, 1000.0),
    Setting('measurement_timeout_s', 0.5, 'torque silence before holding the set-point', 's',
            0.01, 60.0),
    Setting('torque_filter_s', 1000.0, 'time constant of the reference-torque low-pass', 's',
            0.1, 1e6),
    Setting('max_surface_torque_Nm', 2.0e5, 'surface torque samples beyond this either way '
            'are refused as corrupt', 'N m', 1e-3, 1e9, read_only=True),
    Setting('max_torque_jump_Nm', 5.0e4, 'a surface torque sample this far from the last '
            'accepted one is taken only when the next sample confirms it', 'N m', 1e-3, 1e9,
            read_only=True),
)

RECORDER_SETTINGS = (
    Setting('path', '', 'output .mcap file; "" = $ROS_HOME/drill_twin/mcap_recorder_<UTC time>'
            '.mcap', read_only=True),
    Setting('topics', [''], 'topics to record (names of the twin interface); default all',
            read_only=True),
    Setting('chunk_period_s', 0.25, 'longest span one chunk holds = most a kill can lose', 's',
            0.01, 10.0, read_only=True),
)

ESTIMATOR_SETTINGS = (
    Setting('config', 'benchmark_fem', 'string configuration of the estimator\'s model '
            '(units: si, model.type: fem)', read_only=True),
    Setting('overrides', [''], 'configuration overrides KEY=VALUE (dotted keys)',
            read_only=True),
    Setting('rate_hz', 100.0, 'sampling and update rate', 'Hz', 10.0, 1000.0, read_only=True),
    Setting('speed_noise_rad_s', 0.157, 'standard deviation of the top-drive speed sensor',
            'rad/s', 1e-6, 100.0, read_only=True),
    Setting('torque_noise_Nm', 100.0, 'standard deviation of the surface torque sensor',
            'N m', 1e-6, 1e6, read_only=True),
    Setting('hook_load_noise_N', 1.0e4, 'standard deviation of the hook-load sensor', 'N',
            1e-6, 1e8, read_only=True),
    Setting('block_velocity_noise_m_s', 5.0e-3, 'standard deviation of the block velocity',
            'm/s', 1e-9, 10.0, read_only=True),
    Setting('torque_rate_Nm', 10.0, 'random-walk intensity of the torque on bit',
            'N m/s^0.5', 1e-3, 1e6, read_only=True),
    Setting('measurement_timeout_s', 0.5, 'surface-torque silence before the estimates are '
            'held (and diagnostics warn)', 's', 0.01, 60.0),
    Setting('self_tuning_period_s', 120.0, 'period of the self-tuning fit, 0 = off', 's',
            0.0, 3600.0),
    Setting('tuning_window_s', 60.0, 'surface data the self-tuning fit uses', 's', 20.0,
            600.0, read_only=True),
    Setting('self_tuning_apply', True, 'continue on the fitted string (false: only report '
            'the fit and the mismatch warning)'),
    Setting('max_surface_speed_rad_s', 40.0, 'top-drive speed samples beyond this either way '
            'are refused as corrupt', 'rad/s', 1e-3, 1e4, read_only=True),
    Setting('max_surface_torque_Nm', 2.0e5, 'surface torque samples beyond this either way '
            'are refused as corrupt', 'N m', 1e-3, 1e9, read_only=True),
    Setting('max_hook_load_N', 2.0e7, 'hook-load samples below 0 or above this are refused '
            'as corrupt', 'N', 1e-3, 1e10, read_only=True),
    Setting('max_block_speed_m_s', 10.0, 'block velocity samples beyond this either way are '
            'refused as corrupt', 'm/s', 1e-6, 1e3, read_only=True),
)

OPCUA_SETTINGS = (
    Setting('endpoint', 'opc.tcp://127.0.0.1:4840/drill_twin/', 'OPC UA endpoint; only '
            '127.0.0.1/localhost/::1 is served without security (docs/opcua.md)',
            read_only=True),
    Setting('security_dir', '', 'server certificate, trusted client certificates and users '
            '(drill-twin opcua); "" = $ROS_HOME/drill_twin/opcua', read_only=True),
    Setting('config', 'rig_fem', 'the twin\'s configuration: the set-point ranges and which '
            'hoisting set-point applies (units: si)', read_only=True),
    Setting('twin_node', 'drill_twin', 'name of the twin node (its reset, pause and '
            'start_scenario services)', read_only=True),
    Setting('max_surface_speed_rad_s', 40.0, 'largest accepted Rotation.Setpoint (as the '
            'twin\'s parameter)', 'rad/s', 0.1, 100.0, read_only=True),
    Setting('max_refresh_delay_s', 0.5, 'initial MaxRefreshDelay of each function', 's',
            0.05, 10.0, read_only=True),
    Setting('max_torque_Nm', 1.0e5, 'Rotation.MaxTorque of a twin without a motor top drive '
            '(reported against only); with one, MaxTorque starts at the drive\'s rated limit',
            'N m', 0.0, 1.0e6, read_only=True),
)


def ros_home() -> str:
    """``$ROS_HOME``, or ``~/.ros`` (where ROS keeps logs; recordings default below it)."""
    return os.environ.get('ROS_HOME') or os.path.join(os.path.expanduser('~'), '.ros')
