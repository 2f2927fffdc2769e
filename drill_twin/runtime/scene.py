"""The string and the well in 3-D: ``visualization_msgs/MarkerArray`` and tf2 frames of a
:class:`~drill_twin.runtime.digital_twin.DigitalTwin` (plain data, no ROS here).

Frames (REP-103, metres): ``well`` has its origin at the wellhead (the rotary table), x
east, y north, z up, so that a vertical hole runs along -z; ``surface``, ``top_drive`` and
``bit`` have x along the string axis pointing down-hole (the frame of the twin's
``surface/*`` and ``bit/*`` topics; at the bit, the well path's tangent), ``top_drive`` and
``bit`` turned about that axis by the top drive's and the bit's angle.  A node at measured
depth s [m] sits on the configured well path (``well.survey``; vertical without one: z = -s),
above the wellhead straight up, below the survey's end along its last tangent.

What is published (the twin node, ``drill-twin simulate --out x.mcap`` and the live view
alike, at :data:`SCENE_RATE_HZ` of simulated time, not at the 100 Hz tick):

* ``/tf``: ``well -> top_drive`` (z = -block position) and ``well -> bit`` (z = -(string
  length + bit displacement));
* ``string/markers``: the string as a line strip through its nodes (finite-element strings:
  every node; lumped models: top and bit), each point coloured by that node's angular speed
  (:func:`speed_colour`), the bit as a sphere (red while it is stuck) and a text label;
* ``string/profile``: ``std_msgs/Float64MultiArray``, row-major 5 x nodes (top first):
  measured depth [m], angular speed [rad/s], torque [N·m] and tension [N] in the element
  below the node (at the bit: the torque and minus the weight on bit), and the wall's
  contact force on the node [N] (0 in a vertical well); ``layout.dim[0].label`` names the
  five rows (:data:`PROFILE_ROWS`), ``dim[1]`` is ``node``;
* latched, once: ``/tf_static`` (``well -> surface``), ``well/markers`` (the borehole and
  the rig floor) and ``well/path`` (``nav_msgs/Path`` through the survey's stations, each
  pose's x along the hole).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ['StringScene', 'speed_colour', 'string_profile', 'SCENE_RATE_HZ', 'DOWN',
           'axis_rotation', 'PROFILE_ROWS', 'along_hole']

#: the rows of ``string/profile``
PROFILE_ROWS = ('measured_depth_m', 'angular_speed_rad_s', 'torque_Nm', 'tension_N',
                'contact_force_N')

#: scene publish rate [Hz of simulated time]: a 3-D view needs no more, the tick stays cheap
SCENE_RATE_HZ = 10.0
#: quaternion (x, y, z, w) turning x onto -z: the string axis, down-hole, in ``well``
DOWN = (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))
#: marker types and actions of ``visualization_msgs/Marker``
_SPHERE, _CYLINDER, _LINE_STRIP, _TEXT, _CUBE = 2, 3, 4, 9, 1


def axis_rotation(angle_rad: float, along=None) -> dict:
    """Orientation (``geometry_msgs/Quaternion`` fields) of a frame whose x points down-hole,
    turned by ``angle_rad`` [rad] about that axis: ``DOWN ⊗ q_x(angle)`` in a vertical hole,
    ``along_hole(t) ⊗ q_x(angle)`` along the unit tangent ``t`` (well frame) otherwise."""
    s, c = math.sin(0.5 * angle_rad), math.cos(0.5 * angle_rad)
    if along is None:
        r = math.sqrt(0.5)
        return {'x': r * s, 'y': r * c, 'z': -r * s, 'w': r * c}
    a = along_hole(along)
    ax, ay, az, aw = a['x'], a['y'], a['z'], a['w']
    return {'x': aw * s + ax * c, 'y': ay * c + az * s, 'z': az * c - ay * s,
            'w': aw * c - ax * s}


def along_hole(tangent) -> dict:
    """The quaternion that turns x onto the unit vector ``tangent`` (well frame, x east,
    y north, z up) by the shortest rotation (about x × t); straight down it is ``DOWN``."""
    tx, ty, tz = (float(v) for v in tangent)
    w = 1.0 + tx                                   # cos θ + 1 for axis x × t, unnormalised
    if w < 1e-12:                                  # t = -x: half a turn about z
        return {'x': 0.0, 'y': 0.0, 'z': 1.0, 'w': 0.0}
    x, y, z = 0.0, -tz, ty                         # x × t
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return {'x': x / n, 'y': y / n, 'z': z / n, 'w': w / n}


def speed_colour(speed_rad_s: float, reference_rad_s: float) -> dict:
    """``std_msgs/ColorRGBA`` of an angular speed [rad/s]: blue at rest (stuck), green at the
    reference speed, red at twice it and beyond (the slip phase's overshoot)."""
    r = min(max(speed_rad_s / (2.0 * reference_rad_s), 0.0), 1.0) if reference_rad_s > 0 \
        else 0.0
    if r < 0.5:
        f = r / 0.5
        rgb = (0.1, 0.3 + 0.5 * f, 1.0 - 0.8 * f)
    else:
        f = (r - 0.5) / 0.5
        rgb = (0.1 + 0.9 * f, 0.8 - 0.6 * f, 0.2 - 0.1 * f)
    return {'r': rgb[0], 'g': rgb[1], 'b': rgb[2], 'a': 1.0}


def _nodal(chain, values, bit_value, top_value, nodes):
    """Physical values of a chain's DOFs at the string's ``nodes`` nodes, top first: a
    reduced chain expanded, the state's perturbations moved onto the moving reference so
    that the bit has ``bit_value`` (the measurement), an eliminated top node given
    ``top_value``."""
    if hasattr(chain, 'expand'):
        values = chain.expand(values)
    values = np.asarray(values, float)
    values = values + (bit_value - values[-1])
    if values.size == nodes - 1:
        values = np.concatenate([[top_value], values])
    return values


def string_profile(twin, m: dict | None = None, cos_inclination=None) -> dict:
    """The string now, node by node from the top (``string/profile``, module docstring):
    ``depth_m`` (= ``measured_depth_m``: each node's station along the configured string,
    the top 0 and the bit the string's length, moved by its axial displacement [m]),
    ``angular_speed_rad_s`` (= ``speed_rad_s``), ``torque_Nm`` and ``tension_N`` (in the
    element below the node; at the bit the torque on bit and minus the weight on bit) and
    ``contact_force_N`` (the wall's normal force on the node).  Finite-element strings give
    every node, lumped models the top and the bit.  ``m``: the tick's measurements (default:
    :meth:`~drill_twin.runtime.digital_twin.DigitalTwin.peek`); ``cos_inclination``: cos I
    at every element's middle in a deviated well (the tension's weight is its axial part)."""
    m = twin.peek() if m is None else m
    sim = twin.sim
    lengths = getattr(sim.model, 'element_lengths_m', None)
    if lengths is None:
        lengths = getattr(twin.scenario.model, 'element_lengths_m', None)
    if lengths is None:                  # lumped: the top and the bit
        length = sum(sec.length_m for sec in twin.scenario.system.sections)
        depth = np.array([m['block_position_m'], length + m['bit_depth_m']])
        return _named(depth, np.array([m['top_drive_speed_rad_s'],
                                       m['bit_angular_speed_rad_s']]),
                      np.array([m['surface_torque_Nm'], m['torque_on_bit_Nm']]),
                      np.array([m['hook_load_N'], -m['weight_on_bit_N']]), np.zeros(2))
    stations = np.concatenate([[0.0], np.cumsum(lengths)])
    nodes = stations.size
    sl = sim.slices()
    speed = _nodal(sim.model.torsional, sim.x[sl['omega']] / twin.scales.time_s,
                   m['bit_angular_speed_rad_s'],
                   m['top_drive_speed_rad_s'], nodes) if sim.model.torsional is not None \
        else np.zeros(0)
    axial = _nodal(sim.model.axial, sim.x[sl['u']] * twin.scales.depth_m, m['bit_depth_m'],
                   m['block_position_m'], nodes)
    if speed.size != nodes:              # an unexpected layout: no shape along the string
        speed = np.interp(stations, [0.0, stations[-1]], [m['top_drive_speed_rad_s'],
                                                           m['bit_angular_speed_rad_s']])
    if axial.size != nodes:
        axial = np.interp(stations, [0.0, stations[-1]], [m['block_position_m'],
                                                           m['bit_depth_m']])
    torque = np.append(_element_torques(twin, nodes, m), m['torque_on_bit_Nm'])
    tension = np.append(_element_tensions(twin, nodes, m, cos_inclination),
                        -m['weight_on_bit_N'])
    return _named(stations + axial, speed, torque, tension, _contact_forces(twin, nodes))


def _named(depth, speed, torque, tension, contact) -> dict:
    return {'depth_m': depth, 'measured_depth_m': depth, 'speed_rad_s': speed,
            'angular_speed_rad_s': speed, 'torque_Nm': torque, 'tension_N': tension,
            'contact_force_N': contact}


def _element_torques(twin, nodes, m) -> np.ndarray:
    """Torque in every element [N·m], top to bottom: the steady torque plus the elastic
    twist's (perturbation) change; an eliminated top node's element ties to the motor."""
    sim, chain = twin.sim, twin.sim.model.torsional
    scale = twin.scales.torque_Nm
    if chain is None:
        return np.full(nodes - 1, m['surface_torque_Nm'])
    phi = sim.x[sim.slices()['phi']]
    if hasattr(chain, 'expand'):
        chain, phi = chain.full, chain.expand(phi)
    k = -chain.stiffness[2, :-1]
    twist = k * (phi[:-1] - phi[1:])
    if chain.n == nodes - 1:             # the prescribed top: coupled to the motor angle
        theta = sim.x[sim.slices()['drive_angle']][0]
        twist = np.concatenate([[chain.k_top * (theta - phi[0])], twist])
    if twist.size != nodes - 1:
        return np.full(nodes - 1, m['surface_torque_Nm'])
    return (twin.scenario.groups.T_o + twist) * scale


def _element_tensions(twin, nodes, m, cos_inclination=None) -> np.ndarray:
    """Tension in every element [N] (:func:`~drill_twin.physics.statics.element_tension_N`),
    or the hook load throughout where it cannot be had."""
    from ..physics.statics import element_tension_N
    try:
        tension = element_tension_N(twin.scenario, twin.sim, cos_inclination)
    except (ValueError, AttributeError, TypeError):
        tension = None
    if tension is None or tension.size != nodes - 1:
        return np.full(nodes - 1, m['hook_load_N'])
    return tension


def _contact_forces(twin, nodes) -> np.ndarray:
    """The wall's normal force on every node [N] (0 in a vertical well)."""
    from ..physics.layout import WALL
    out = np.zeros(nodes)
    wall = twin.sim.wall
    mu = (twin.scenario.raw.get('well') or {}).get('friction_factor', 0.0) or 0.0
    if wall.shape[1] == 0 or mu <= 0.0:
        return out
    s = twin.scales
    force = s.mass_kg * s.depth_m / s.time_s ** 2
    offset = nodes - twin.sim.n_axial
    out[wall[WALL.axial_dof].astype(int) + offset] = wall[WALL.static] * force / mu
    return out


def _header(stamp, frame='well'):
    return {'stamp': stamp, 'frame_id': frame}


def _point(depth_m):
    return {'x': 0.0, 'y': 0.0, 'z': -float(depth_m)}


class _Hole:
    """Points and tangents of the well path in the well frame (module docstring)."""

    def __init__(self, path):
        self.path = path
        self.depth_m = path.total_depth_m
        self.end = self._enu(path.position(self.depth_m))
        self.end_tangent = self._enu(path.tangent(self.depth_m))

    @staticmethod
    def _enu(ned):
        ned = np.asarray(ned, float)
        return np.stack([ned[..., 1], ned[..., 0], -ned[..., 2]], axis=-1)

    def points(self, depth_m) -> np.ndarray:
        """(x, y, z) [m] of measured depths ``depth_m`` [m], shape (..., 3)."""
        md = np.asarray(depth_m, float)
        inside = np.clip(md, 0.0, self.depth_m)
        out = self._enu(self.path.position(inside))
        out[..., 2] -= np.minimum(md, 0.0)                     # above the wellhead: up
        beyond = np.maximum(md - self.depth_m, 0.0)[..., None]
        return out + beyond * self.end_tangent                 # below the survey: straight on

    def tangent(self, depth_m) -> np.ndarray:
        md = float(np.clip(depth_m, 0.0, self.depth_m))
        return self._enu(self.path.tangent(md))


def _xyz(p) -> dict:
    return {'x': float(p[0]), 'y': float(p[1]), 'z': float(p[2])}


class StringScene:
    """The 3-D scene of one twin (module docstring).

    Parameters
    ----------
    twin : DigitalTwin
        The twin drawn.
    rate_hz : float
        Scene messages per second of simulated time [Hz].
    """

    def __init__(self, twin, rate_hz: float = SCENE_RATE_HZ):
        self.twin = twin
        self.period_s = 1.0 / float(rate_hz)
        self._next_s = None
        system = twin.scenario.system
        #: the configured string's length [m] (measured depth of the bit at rest)
        self.length_m = float(sum(sec.length_m for sec in system.sections))
        self.bit_radius_m = float(getattr(system, 'bit_radius_m', 0.1))
        #: the speed coloured green [rad/s]: the configuration's operating point
        self.reference_rad_s = float(twin.scenario.groups.omega_o / twin.scales.time_s)
        #: line width and marker size [m]: visible at the scale of the whole string
        self.width_m = max(0.005 * self.length_m, 2.0 * self.bit_radius_m)
        self.hole = _Hole(_well_path(twin.scenario, self.length_m))
        lengths = getattr(twin.scenario.model, 'element_lengths_m', None)
        #: cos I at every element's middle (None: a vertical well or a lumped model)
        self.cos_inclination = None
        if lengths is not None and twin.scenario.wall is not None:
            stations = np.concatenate([[0.0], np.cumsum(lengths)])
            middles = np.minimum(0.5 * (stations[:-1] + stations[1:]), self.hole.depth_m)
            self.cos_inclination = np.cos(self.hole.path.inclination(middles))

    # --- latched --------------------------------------------------------------------
    def static_messages(self, stamp: dict) -> list:
        """``[(topic, fields)]`` of the latched scene: ``/tf_static`` and ``well/markers``."""
        tf = {'transforms': [{'header': _header(stamp), 'child_frame_id': 'surface',
                              'transform': {'rotation': dict(zip('xyzw', DOWN))}}]}
        hole = self.length_m * 1.02
        well = {'markers': [
            {'header': _header(stamp), 'ns': 'well', 'id': 0, 'type': _CYLINDER,
             'pose': {'position': {'z': -0.5 * hole}, 'orientation': {'w': 1.0}},
             'scale': {'x': 4.0 * self.width_m, 'y': 4.0 * self.width_m, 'z': hole},
             'color': {'r': 0.55, 'g': 0.45, 'b': 0.35, 'a': 0.25}},
            {'header': _header(stamp), 'ns': 'well', 'id': 1, 'type': _CUBE,
             'pose': {'position': {'z': 0.5 * self.width_m}, 'orientation': {'w': 1.0}},
             'scale': {'x': 20.0 * self.width_m, 'y': 20.0 * self.width_m,
                       'z': self.width_m},
             'color': {'r': 0.4, 'g': 0.4, 'b': 0.4, 'a': 0.8}}]}
        return [('/tf_static', tf), ('well/markers', well), ('well/path', self.path_fields(stamp))]

    def path_fields(self, stamp: dict) -> dict:
        """``nav_msgs/Path`` of the well (frame ``well``): a pose at every survey station
        down to the bit's depth (and at the bit), each with x along the hole."""
        stations = self.hole.path.measured_depth_m
        depths = np.union1d(stations[stations < self.length_m],
                            [min(self.length_m, self.hole.depth_m)])
        points = self.hole.points(depths)
        return {'header': _header(stamp), 'poses': [
            {'header': _header(stamp), 'pose': {
                'position': _xyz(p), 'orientation': along_hole(self.hole.tangent(d))}}
            for d, p in zip(depths, points)]}

    # --- every scene period -------------------------------------------------------------
    def due(self, time_s: float) -> bool:
        """True when the scene is to be drawn at simulated time ``time_s`` [s] (the first
        call and then every :attr:`period_s`, on a fixed grid of simulated time)."""
        if self._next_s is not None and time_s < self._next_s - 1e-9:
            return False
        self._next_s = (math.floor(time_s / self.period_s + 1e-9) + 1) * self.period_s
        return True

    def messages(self, m: dict, stamp: dict) -> list:
        """``[(topic, fields)]`` of ``/tf`` and ``string/markers`` for the tick's
        measurements ``m`` when the scene is due (:meth:`due`), else ``[]``."""
        if not self.due(m['time_s']):
            return []
        return self.draw(m, stamp)

    def draw(self, m: dict, stamp: dict) -> list:
        """``/tf``, ``string/markers`` and ``string/profile`` now (whether due or not)."""
        profile = string_profile(self.twin, m, self.cos_inclination)
        bit_depth = float(profile['depth_m'][-1])
        points = self.hole.points(profile['depth_m'])
        bit_at = _xyz(points[-1])
        tf = {'transforms': [
            {'header': _header(stamp), 'child_frame_id': 'top_drive', 'transform': {
                'translation': _point(m['block_position_m']),
                'rotation': axis_rotation(m['top_drive_angle_rad'])}},
            {'header': _header(stamp), 'child_frame_id': 'bit', 'transform': {
                'translation': bit_at,
                'rotation': axis_rotation(m['bit_angle_rad'],
                                          self.hole.tangent(bit_depth))}}]}
        ref = self.reference_rad_s
        stuck = bool(m['stuck'])
        rpm = m['bit_angular_speed_rad_s'] * 60.0 / (2.0 * math.pi)
        markers = {'markers': [
            {'header': _header(stamp), 'ns': 'string', 'id': 0, 'type': _LINE_STRIP,
             'pose': {'orientation': {'w': 1.0}}, 'scale': {'x': self.width_m},
             'color': {'r': 1.0, 'g': 1.0, 'b': 1.0, 'a': 1.0},
             'points': [_xyz(p) for p in points],
             'colors': [speed_colour(w, ref) for w in profile['speed_rad_s']]},
            {'header': _header(stamp), 'ns': 'bit', 'id': 1, 'type': _SPHERE,
             'pose': {'position': bit_at, 'orientation': {'w': 1.0}},
             'scale': {'x': 3 * self.width_m, 'y': 3 * self.width_m, 'z': 3 * self.width_m},
             'color': {'r': 1.0, 'g': 0.1, 'b': 0.1, 'a': 1.0} if stuck
             else {'r': 0.8, 'g': 0.8, 'b': 0.8, 'a': 1.0}},
            {'header': _header(stamp), 'ns': 'bit', 'id': 2, 'type': _TEXT,
             'pose': {'position': {**bit_at, 'x': bit_at['x'] + 6 * self.width_m},
                      'orientation': {'w': 1.0}},
             'scale': {'z': 4 * self.width_m},
             'color': {'r': 1.0, 'g': 0.2, 'b': 0.2, 'a': 1.0} if stuck
             else {'r': 1.0, 'g': 1.0, 'b': 1.0, 'a': 1.0},
             'text': ('STUCK' if stuck else f'bit {rpm:.0f} rpm')}]}
        return [('/tf', tf), ('string/markers', markers),
                ('string/profile', _profile_fields(profile))]


def _profile_fields(profile: dict) -> dict:
    """``std_msgs/Float64MultiArray`` of a :func:`string_profile` (module docstring)."""
    rows = np.vstack([profile[key] for key in PROFILE_ROWS])
    nodes = rows.shape[1]
    return {'layout': {'dim': [
        {'label': ','.join(PROFILE_ROWS), 'size': len(PROFILE_ROWS),
         'stride': len(PROFILE_ROWS) * nodes},
        {'label': 'node', 'size': nodes, 'stride': nodes}], 'data_offset': 0},
        'data': [float(v) for v in rows.ravel()]}


def _well_path(scenario, length_m):
    """The configured well path of an SI scenario, else the vertical well."""
    from ..physics.well_path import WellPath
    if scenario.system is None:
        return WellPath.vertical(length_m)
    from ..config.well import scenario_well
    return scenario_well(scenario)
