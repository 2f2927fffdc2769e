"""The string and the well in 3-D: ``visualization_msgs/MarkerArray`` and tf2 frames of a
:class:`~drill_twin.runtime.digital_twin.DigitalTwin` (plain data, no ROS here).

Frames (REP-103, metres): ``well`` has its origin at the wellhead (the rotary table), z up,
so that a vertical hole runs along -z; ``surface``, ``top_drive`` and ``bit`` have x along
the string axis pointing down-hole (the frame of the twin's ``surface/*`` and ``bit/*``
topics), ``top_drive`` and ``bit`` turned about that axis by the top drive's and the bit's
angle.  The well is vertical today: a node at measured depth s [m] is at z = -s.

What is published (the twin node, ``drill-twin simulate --out x.mcap`` and the live view
alike, at :data:`SCENE_RATE_HZ` of simulated time, not at the 100 Hz tick):

* ``/tf``: ``well -> top_drive`` (z = -block position) and ``well -> bit`` (z = -(string
  length + bit displacement));
* ``string/markers``: the string as a line strip through its nodes (finite-element strings:
  every node; lumped models: top and bit), each point coloured by that node's angular speed
  (:func:`speed_colour`), the bit as a sphere (red while it is stuck) and a text label;
* latched, once: ``/tf_static`` (``well -> surface``) and ``well/markers`` (the borehole and
  the rig floor).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ['StringScene', 'speed_colour', 'string_profile', 'SCENE_RATE_HZ', 'DOWN',
           'axis_rotation']

#: scene publish rate [Hz of simulated time]: a 3-D view needs no more, the tick stays cheap
SCENE_RATE_HZ = 10.0
#: quaternion (x, y, z, w) turning x onto -z: the string axis, down-hole, in ``well``
DOWN = (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))
#: marker types and actions of ``visualization_msgs/Marker``
_SPHERE, _CYLINDER, _LINE_STRIP, _TEXT, _CUBE = 2, 3, 4, 9, 1


def axis_rotation(angle_rad: float) -> dict:
    """Orientation (``geometry_msgs/Quaternion`` fields) of a frame whose x points down-hole,
    turned by ``angle_rad`` [rad] about that axis: ``DOWN ⊗ q_x(angle)``."""
    s, c = math.sin(0.5 * angle_rad), math.cos(0.5 * angle_rad)
    r = math.sqrt(0.5)
    return {'x': r * s, 'y': r * c, 'z': -r * s, 'w': r * c}


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


def string_profile(twin, m: dict | None = None) -> dict:
    """The string now: ``depth_m`` (measured depth of every node [m]: its station along the
    configured string, the top 0 and the bit the string's length, moved by its axial
    displacement) and ``speed_rad_s`` (each node's angular speed [rad/s]); finite-element
    strings give every node, lumped models the top and the bit.  ``m``: the tick's
    measurements (default: :meth:`~drill_twin.runtime.digital_twin.DigitalTwin.peek`)."""
    m = twin.peek() if m is None else m
    sim = twin.sim
    lengths = getattr(sim.model, 'element_lengths_m', None)
    if lengths is None:
        lengths = getattr(twin.scenario.model, 'element_lengths_m', None)
    if lengths is None:                  # lumped: the top and the bit
        length = sum(sec.length_m for sec in twin.scenario.system.sections)
        return {'depth_m': np.array([m['block_position_m'], length + m['bit_depth_m']]),
                'speed_rad_s': np.array([m['top_drive_speed_rad_s'],
                                         m['bit_angular_speed_rad_s']])}
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
    return {'depth_m': stations + axial, 'speed_rad_s': speed}


def _header(stamp, frame='well'):
    return {'stamp': stamp, 'frame_id': frame}


def _point(depth_m):
    return {'x': 0.0, 'y': 0.0, 'z': -float(depth_m)}


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
        return [('/tf_static', tf), ('well/markers', well)]

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
        """``/tf`` and ``string/markers`` now (whether due or not)."""
        profile = string_profile(self.twin, m)
        bit_depth = float(profile['depth_m'][-1])
        tf = {'transforms': [
            {'header': _header(stamp), 'child_frame_id': 'top_drive', 'transform': {
                'translation': _point(m['block_position_m']),
                'rotation': axis_rotation(m['top_drive_angle_rad'])}},
            {'header': _header(stamp), 'child_frame_id': 'bit', 'transform': {
                'translation': _point(bit_depth),
                'rotation': axis_rotation(m['bit_angle_rad'])}}]}
        ref = self.reference_rad_s
        stuck = bool(m['stuck'])
        rpm = m['bit_angular_speed_rad_s'] * 60.0 / (2.0 * math.pi)
        markers = {'markers': [
            {'header': _header(stamp), 'ns': 'string', 'id': 0, 'type': _LINE_STRIP,
             'pose': {'orientation': {'w': 1.0}}, 'scale': {'x': self.width_m},
             'color': {'r': 1.0, 'g': 1.0, 'b': 1.0, 'a': 1.0},
             'points': [_point(d) for d in profile['depth_m']],
             'colors': [speed_colour(w, ref) for w in profile['speed_rad_s']]},
            {'header': _header(stamp), 'ns': 'bit', 'id': 1, 'type': _SPHERE,
             'pose': {'position': _point(bit_depth), 'orientation': {'w': 1.0}},
             'scale': {'x': 3 * self.width_m, 'y': 3 * self.width_m, 'z': 3 * self.width_m},
             'color': {'r': 1.0, 'g': 0.1, 'b': 0.1, 'a': 1.0} if stuck
             else {'r': 0.8, 'g': 0.8, 'b': 0.8, 'a': 1.0}},
            {'header': _header(stamp), 'ns': 'bit', 'id': 2, 'type': _TEXT,
             'pose': {'position': {'x': 6 * self.width_m, 'z': -bit_depth},
                      'orientation': {'w': 1.0}},
             'scale': {'z': 4 * self.width_m},
             'color': {'r': 1.0, 'g': 0.2, 'b': 0.2, 'a': 1.0} if stuck
             else {'r': 1.0, 'g': 1.0, 'b': 1.0, 'a': 1.0},
             'text': ('STUCK' if stuck else f'bit {rpm:.0f} rpm')}]}
        return [('/tf', tf), ('string/markers', markers)]
