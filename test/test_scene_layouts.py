"""The string in 3-D and the shipped layouts (issue 35).

* the MarkerArray's line strip lies on the configured string: one point per node, on the
  well's vertical axis, at the nodes' measured depths (within their axial displacement),
  the top at the wellhead and the last point at the bit; coloured by angular speed, the
  bit marked when stuck; tf frames well -> top_drive, bit at the same depths;
* a recording of the default twin run holds every topic the shipped Foxglove and
  PlotJuggler layouts name (the estimator's only when it runs).
"""
import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from drill_twin import topics as T
from drill_twin.config.scenario import load_scenario
from drill_twin.io.mcap_reader import open_recording
from drill_twin.io.run_recorder import record_run
from drill_twin.runtime.digital_twin import DigitalTwin
from drill_twin.runtime.scene import (
    PROFILE_ROWS,
    StringScene,
    axis_rotation,
    speed_colour,
    string_profile,
)

LAYOUTS = Path(__file__).resolve().parents[1] / 'layouts'


@pytest.fixture(scope='module')
def recording(tmp_path_factory):
    """The default twin (the node's configuration, rig_fem) recorded for 2 s."""
    path = tmp_path_factory.mktemp('scene') / 'default.mcap'
    record_run(load_scenario('rig_fem'), path, 2.0, config='rig_fem')
    return open_recording(path)


def _rotate(q, v):
    """Rotate vector ``v`` by the unit quaternion ``q`` (dict x, y, z, w)."""
    x, y, z, w = q['x'], q['y'], q['z'], q['w']
    u = np.array([x, y, z])
    v = np.asarray(v, float)
    return 2 * u.dot(v) * u + (w * w - u.dot(u)) * v + 2 * w * np.cross(u, v)


def test_the_string_axis_points_down_hole_and_turns_about_it():
    for angle in (0.0, 0.7, 4.0):
        q = axis_rotation(angle)
        assert math.isclose(sum(c * c for c in q.values()), 1.0)
        assert np.allclose(_rotate(q, [1, 0, 0]), [0, 0, -1])        # x: down the hole
        # y turns in the horizontal plane by the angle (about the down-hole axis)
        y = _rotate(q, [0, 1, 0])
        assert y[2] == pytest.approx(0.0, abs=1e-12)
        assert np.allclose(y[:2], [-math.sin(angle), math.cos(angle)]) or \
            np.allclose(y[:2], [math.sin(angle), math.cos(angle)])


def test_speed_colours_run_from_blue_at_rest_to_red_at_twice_the_reference():
    assert speed_colour(0.0, 10.0)['b'] > 0.9 and speed_colour(0.0, 10.0)['r'] < 0.2
    assert speed_colour(10.0, 10.0)['g'] > 0.7
    assert speed_colour(25.0, 10.0)['r'] == 1.0


@pytest.mark.parametrize('config', ['rig_fem', 'benchmark_fem'])
def test_the_marker_points_lie_on_the_configured_string(config):
    scenario = load_scenario(config)
    twin = DigitalTwin(scenario)
    twin.advance_to(3.0)
    m = twin.measurements()
    scene = StringScene(twin)
    (tf_name, tf), (name, markers), (profile_name, _) = scene.messages(
        m, T.stamp_fields(m['time_s']))
    assert (tf_name, name, profile_name) == ('/tf', 'string/markers', 'string/profile')
    line = markers['markers'][0]
    points = np.array([[p['x'], p['y'], p['z']] for p in line['points']])
    lengths = scenario.model.element_lengths_m
    stations = np.concatenate([[0.0], np.cumsum(lengths)])
    length = sum(sec.length_m for sec in scenario.system.sections)
    assert stations[-1] == pytest.approx(length)
    assert len(points) == len(stations) == len(line['colors'])
    assert np.all(points[:, :2] == 0.0)                         # vertical well: on the axis
    depth = -points[:, 2]
    assert np.all(np.diff(depth) > 0)                           # top to bit, in order
    # each node at its station, moved only by its axial displacement (mm here)
    assert np.max(np.abs(depth - stations)) < 0.05
    assert depth[-1] == pytest.approx(length + m['bit_depth_m'], abs=1e-9)
    # the colours follow the nodes' speeds: the bit's is the measured bit speed
    profile = string_profile(twin, m)
    assert profile['speed_rad_s'][-1] == pytest.approx(m['bit_angular_speed_rad_s'])
    assert profile['speed_rad_s'][0] == pytest.approx(m['top_drive_speed_rad_s'])
    assert line['colors'][-1] == speed_colour(m['bit_angular_speed_rad_s'],
                                              scene.reference_rad_s)
    frames = {t['child_frame_id']: t for t in tf['transforms']}
    assert set(frames) == {'top_drive', 'bit'}
    assert frames['bit']['transform']['translation']['z'] == pytest.approx(-depth[-1])
    assert frames['top_drive']['transform']['translation']['z'] == \
        pytest.approx(-m['block_position_m'])
    bit = markers['markers'][1]
    assert bit['pose']['position']['z'] == pytest.approx(-depth[-1])


def test_the_profile_carries_the_steady_torque_and_the_weight_down_the_string():
    """Vertical benchmark string drilling steadily: the torque is the same in every element
    (no wall: nothing takes torque between top and bit) and equals the surface torque; the
    tension falls from the hook load to minus the WOB by the buoyed weight below each
    element (thesis §2.1: H = ∫ f_u dx - W)."""
    scenario = load_scenario('benchmark_fem', [f'simulation.initial_perturbation.{k}=0'
                                               for k in ('u', 'v', 'phi', 'omega')])
    twin = DigitalTwin(scenario)
    m = twin.measurements()
    fields = StringScene(twin).draw(m, T.stamp_fields(0.0))[2][1]
    rows, nodes = (d['size'] for d in fields['layout']['dim'])
    assert fields['layout']['dim'][0]['label'].split(',') == list(PROFILE_ROWS)
    p = dict(zip(PROFILE_ROWS, np.array(fields['data']).reshape(rows, nodes)))
    system = scenario.system
    assert nodes == len(scenario.model.element_lengths_m) + 1
    assert p['torque_Nm'][:-1] == pytest.approx(m['surface_torque_Nm'], rel=1e-9)
    assert p['torque_Nm'][-1] == pytest.approx(m['torque_on_bit_Nm'])
    weight = system.buoyed_weight_N()
    assert p['tension_N'][0] == pytest.approx(weight - m['weight_on_bit_N'], rel=1e-6)
    assert p['tension_N'][-1] == pytest.approx(-m['weight_on_bit_N'])
    assert np.all(np.diff(p['tension_N']) < 0)
    assert np.all(p['contact_force_N'] == 0.0)                  # a vertical well


def test_in_a_deviated_well_the_string_lies_on_the_well_path():
    """Well B: vertical to 500 m, a 60° build of radius R = 1100 m/(π/3) to 1,600 m, then
    straight: at MD 2,500 m the bit is R(1 - cos 60°) + 900 sin 60° north of the wellhead
    and 500 + R sin 60° + 900 cos 60° deep (closed form).  The well/path poses point along
    the hole; the wall's contact force is zero in the vertical part and positive below."""
    scenario = load_scenario('wells/well_b')
    twin = DigitalTwin(scenario)
    m = twin.measurements()
    scene = StringScene(twin)
    stamp = T.stamp_fields(0.0)
    (_, tf), (_, markers), (_, fields) = scene.draw(m, stamp)
    R = 1100.0 / (math.pi / 3)
    north = R * (1 - math.cos(math.pi / 3)) + 900 * math.sin(math.pi / 3)
    depth = 500 + R * math.sin(math.pi / 3) + 900 * math.cos(math.pi / 3)
    bit = markers['markers'][1]['pose']['position']
    # the bit moved by its axial displacement from MD 2,500 m (mm): 0.01 m
    assert (bit['x'], bit['y'], bit['z']) == pytest.approx((0.0, north, -depth), abs=0.01)
    frames = {t['child_frame_id']: t['transform'] for t in tf['transforms']}
    assert frames['bit']['translation'] == pytest.approx(bit)
    path = dict(scene.static_messages(stamp))['well/path']
    poses = path['poses']
    assert path['header']['frame_id'] == 'well'
    assert poses[0]['pose']['position'] == pytest.approx({'x': 0.0, 'y': 0.0, 'z': 0.0})
    end = poses[-1]['pose']
    # summed over 250 legs of 0.55° doglegs (ratio factors in floating point): 1e-4 m
    assert (end['position']['y'], end['position']['z']) == pytest.approx((north, -depth),
                                                                         abs=1e-4)
    q = end['orientation']                                   # x axis of the pose
    x_axis = (1 - 2 * (q['y'] ** 2 + q['z'] ** 2), 2 * (q['x'] * q['y'] + q['w'] * q['z']),
              2 * (q['x'] * q['z'] - q['w'] * q['y']))
    assert x_axis == pytest.approx((0.0, math.sin(math.pi / 3), -math.cos(math.pi / 3)),
                                   abs=1e-12)
    rows, nodes = (d['size'] for d in fields['layout']['dim'])
    p = dict(zip(PROFILE_ROWS, np.array(fields['data']).reshape(rows, nodes)))
    vertical = p['measured_depth_m'] < 499.0
    assert np.all(p['contact_force_N'][vertical] == 0.0)
    # the tension at the top is what the hook carries: the axial part of the weight less
    # the WOB (the elements' cos I at their middles against the statics' integral: the
    # midpoint rule's O(h²) on 12.5 m elements, ~1e-6 here)
    assert p['tension_N'][0] == pytest.approx(m['hook_load_N'], rel=1e-4)
    assert np.all(p['contact_force_N'][p['measured_depth_m'] > 501.0] > 0.0)


def test_the_bit_is_marked_when_stuck():
    twin = DigitalTwin(load_scenario('rig_fem'))
    m = twin.measurements()
    scene = StringScene(twin)
    free = scene.draw({**m, 'stuck': False}, T.stamp_fields(0.0))[1][1]['markers']
    stuck = scene.draw({**m, 'stuck': True}, T.stamp_fields(0.0))[1][1]['markers']
    assert stuck[1]['color']['r'] == 1.0 and stuck[1]['color']['g'] < 0.2
    assert free[1]['color'] != stuck[1]['color']
    assert stuck[2]['text'] == 'STUCK' and 'rpm' in free[2]['text']


def test_the_scene_is_drawn_at_a_few_hz_on_a_grid_of_simulated_time():
    twin = DigitalTwin(load_scenario('rig_fem'))
    scene = StringScene(twin, rate_hz=10.0)
    due = [k for k in range(100) if scene.due(k * 0.01)]
    assert due == list(range(0, 100, 10))


def test_a_recording_holds_the_scene_and_the_latched_geometry(recording):
    topics = recording.topics
    assert topics['/tf'] == 'tf2_msgs/msg/TFMessage'
    assert topics['/string/markers'] == 'visualization_msgs/msg/MarkerArray'
    counts = recording.message_counts
    assert counts['/tf_static'] == 1 and counts['/well/markers'] == 1
    assert counts['/well/path'] == 1
    assert counts['/string/profile'] == counts['/string/markers']
    assert counts['/string/markers'] == pytest.approx(20, abs=1)    # 10 Hz for 2 s
    assert counts['/bit/velocity'] == 200
    decoded = [recording.decoder('/string/markers')(data)
               for _, _, data in recording.messages(['/string/markers'])]
    assert len(decoded[-1].markers[0].points) == 59


def _foxglove_topics(layout: dict) -> set:
    topics = set()
    for config in layout['configById'].values():
        for path in config.get('paths', []):
            topics.add(re.match(r'(/[^.]+)\.', path['value']).group(1))
        topics.update(config.get('topics', {}))
        if config.get('topicToRender'):
            topics.add(config['topicToRender'])
    return topics


def _plotjuggler_topics(root, recorded) -> set:
    topics = set()
    for curve in root.iter('curve'):
        name = curve.get('name')
        prefixes = [t for t in recorded | _estimates() if name.startswith(t + '/')]
        assert prefixes, f'{name}: no topic of the twin'
        topics.add(max(prefixes, key=len))
    for plugin in root.iter('selected_topics'):
        topics.update(plugin.get('value').split(';'))
    return topics


def _estimates() -> set:
    return {'/' + t.name for t in T.ESTIMATE_TOPICS}


def _named_topics(recorded) -> tuple:
    layout = json.loads((LAYOUTS / 'drill_twin.foxglove.json').read_text())
    named = _foxglove_topics(layout)
    named |= _plotjuggler_topics(ET.parse(LAYOUTS / 'drill_twin.plotjuggler.xml').getroot(),
                                 recorded)
    return layout, named


def test_every_topic_the_layouts_name_is_in_a_recording_of_the_default_node(rig, tmp_path):
    """The default launch's twin (its defaults but 5x real time), recording."""
    path = tmp_path / 'node.mcap'
    node = rig.twin(record_path=str(path))
    assert rig.spin_until(lambda: node.twin.time_s > 12.0, 30)   # >= 2 /diagnostics
    node.trigger_deactivate()
    node.trigger_cleanup()                                      # the recording is closed
    recorded = set(open_recording(path).topics)
    layout, named = _named_topics(recorded)
    assert len(named) > 10
    assert named - recorded - _estimates() == set()             # the estimator's: when it runs
    panels = {key.split('!')[0] for key in layout['configById']}
    assert {'Plot', '3D', 'DiagnosticSummary'} <= panels
    assert named & _estimates()
    assert {'/string/markers', '/well/markers', '/diagnostics'} <= named


def test_an_offline_recording_holds_the_layouts_topics_but_the_nodes_diagnostics(recording):
    recorded = set(recording.topics)
    _, named = _named_topics(recorded)
    assert named - recorded - _estimates() == {'/diagnostics'}


def test_the_layouts_are_installed_with_the_package():
    setup = (LAYOUTS.parent / 'setup.py').read_text()
    assert "('share/' + package_name + '/layouts', glob('layouts/*'))" in setup
    assert sorted(p.name for p in LAYOUTS.iterdir()) == ['drill_twin.foxglove.json',
                                                        'drill_twin.plotjuggler.xml']
