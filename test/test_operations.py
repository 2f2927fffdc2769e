"""Operations (issue 14): scenario files offline and in the node, start from rest, the
autodriller, a connection cycle, and the files' own errors."""
import math

import numpy as np
import pytest

from drill_twin.config.lookup import CONFIG_DIR
from drill_twin.errors import ConfigError
from drill_twin.io.mcap_reader import open_recording
from drill_twin.io.resimulation import resimulate
from drill_twin.operations.driller import ScenarioError
from drill_twin.operations.runner import run_timeline
from drill_twin.operations.timeline import load_timeline

SHIPPED = sorted(p.stem for p in (CONFIG_DIR / 'operations').glob('*.yaml'))


def test_the_shipped_scenario_files_are_these():
    assert SHIPPED == ['connection', 'offbottom_startup_well_b', 'rpm_ramp',
                       'startup_from_rest', 'wob_steps']


@pytest.fixture(scope='module')
def startup(tmp_path_factory):
    path = tmp_path_factory.mktemp('ops') / 'startup.mcap'
    return run_timeline('startup_from_rest', out=path), path


@pytest.mark.slow
def test_start_from_rest_tags_bottom_and_drills_at_the_target(startup):
    series, _ = startup
    t = series['time_s']
    log = dict((label.split(' (')[0].split('. ', 1)[1], t0) for t0, label in series['log'])
    # at rest: untwisted, off bottom, the hook carries the buoyed string weight
    # the rest state is set, not integrated: a few scalings between SI and the model's units
    # (round-off ~1e-15 of 1 m, of 4e5 N); 1e-9 leaves orders of magnitude
    assert series['bit_above_bottom_m'][0] == pytest.approx(1.0, abs=1e-9)
    assert series['hook_load_N'][0] == pytest.approx(series['twin'].string_weight_N, rel=1e-9)
    assert abs(series['bit_angular_speed_rad_s'][0]) < 1e-9
    # off bottom nothing touches the rock; after tagging bottom the bit stays on it
    before = t < log['tag bottom']
    assert np.all(series['weight_on_bit_N'][before] == 0.0)
    on = t > log['slack off']
    assert series['bit_above_bottom_m'][on].max() < 0.01   # rebounds of mm after the tag
    assert np.all(series['bit_above_bottom_m'][t > log['drill']] == 0.0)
    # the autodriller holds the target WOB (what the rig infers from the hook load) ...
    drilling = t > log['drill'] + 10.0
    inferred = series['twin'].string_weight_N - series['hook_load_N'][drilling]
    assert inferred.mean() == pytest.approx(60.5e3, rel=0.01)
    # ... and the bit drills: mean ROP against the steady state of the bit law (eq. 2.4.5)
    sc = series['twin'].scenario
    rop_o = sc.groups.upsilon_o * sc.scales.speed_m_s
    assert series['rate_of_penetration_m_s'][drilling].mean() == pytest.approx(rop_o, rel=0.05)


@pytest.mark.slow
def test_a_scenario_run_is_recorded_and_resimulated_exactly(startup):
    _, path = startup
    rec = open_recording(path)
    assert rec.message_counts['/block_velocity_setpoint'] > 10
    report = resimulate(rec)
    worst = max(v['max_abs_difference'] for v in report['topics'].values())
    assert worst == 0.0 and report['ticks'] > 5000


@pytest.mark.slow
def test_connection_cycle_returns_to_the_same_steady_drilling(tmp_path):
    """Drill, pick up, stop the rotary, wait, restart, tag bottom, slack off, drill: at a
    stable operating point (more string damping than the benchmark) the drilling after the
    connection has the statistics of the drilling before it."""
    path = tmp_path / 'connection.yaml'
    path.write_text((CONFIG_DIR / 'operations' / 'connection.yaml').read_text()
                    .replace('overrides: [model.axial_top=hoist]',
                             'overrides: [model.axial_top=hoist, model.theta_u=2e-2, '
                             'model.theta_phi=2e-2, simulation.time_step=auto]')
                    .replace('drill: {for_s: 40}', 'drill: {for_s: 120}')
                    .replace('drill: {for_s: 60}', 'drill: {for_s: 200}'))
    series = run_timeline(path)
    t = series['time_s']
    starts = [t0 for t0, label in series['log']]
    before = (t > starts[1] + 60.0) & (t < starts[2])
    after = t > starts[-1] + 140.0
    for key in ('bit_angular_speed_rad_s', 'rate_of_penetration_m_s', 'weight_on_bit_N',
                'torque_on_bit_Nm', 'surface_torque_Nm'):
        assert series[key][after].mean() == pytest.approx(series[key][before].mean(),
                                                          rel=0.005), key
    # and during the connection the string has unwound, off bottom and at rest
    wait = (t > starts[4] + 50.0) & (t < starts[5])
    assert np.all(series['bit_above_bottom_m'][wait] > 0.9)
    assert np.abs(series['torque_on_bit_Nm'][wait]).max() == 0.0


def _steady_rop_m_s(raw, wob_N, speed_rad_s):
    """Eq. 2.4.5 in SI from the configuration's bit numbers: W = n_b ζ ε a d + n_b a ℓ σ_f,
    V = n_b d Ω / 2π; zero below the wear-flat load (the bit cannot cut)."""
    s = raw['drill_string']
    a, n_b = s['bit_radius_m'], s['blades']
    wear_flat_N = n_b * a * s['wear_flat_length_m'] * s['contact_stress_Pa']
    depth = (wob_N - wear_flat_N) / (n_b * s['cutting_force_ratio_zeta']
                                     * s['intrinsic_specific_energy_Pa'] * a)
    return max(depth, 0.0) * n_b * speed_rad_s / (2 * math.pi), wear_flat_N


def _step_windows(series, last_s):
    """Masks of the last ``last_s`` of every 'drill' step, with the step's label."""
    t = series['time_s']
    starts = [t0 for t0, _ in series['log']] + [t[-1] + 1e-9]
    return [(label, (t > starts[k + 1] - last_s) & (t < starts[k + 1]))
            for k, (_, label) in enumerate(series['log']) if '. drill' in label]


@pytest.mark.slow
def test_wob_steps_drill_at_the_bit_law_rate_of_each_weight():
    """The shipped WOB steps: the autodriller holds each WOB (inferred from the hook load,
    as on a rig) and the bit drills at the steady rate of eq. 2.4.5 for that WOB; at 40 kN,
    below the wear-flat load n_b a ℓ σ_f = 52.3 kN, the bit barely cuts."""
    series = run_timeline('wob_steps')
    twin = series['twin']
    raw = twin.scenario.raw
    speed = raw['operating_point']['surface_speed_rad_s']
    windows = _step_windows(series, 30.0)
    assert len(windows) == 3
    rop_nominal, _ = _steady_rop_m_s(raw, 60.5e3, speed)
    for (label, m), wob, tol in zip(windows, (40e3, 60.5e3, 80e3), (None, 0.03, 0.05)):
        inferred = twin.string_weight_N - series['hook_load_N'][m]
        assert inferred.mean() == pytest.approx(wob, rel=0.01), label
        rop, wear_flat_N = _steady_rop_m_s(raw, wob, speed)
        measured = series['rate_of_penetration_m_s'][m].mean()
        if tol is None:
            assert wob < wear_flat_N and rop == 0.0
            assert measured < 0.15 * rop_nominal, label
        else:
            assert measured == pytest.approx(rop, rel=tol), label


@pytest.mark.slow
def test_rpm_ramp_plateaus_turn_the_bit_at_the_rotary_speed():
    """On each plateau of the shipped rpm ramps the mean bit speed is the rotary speed (the
    string cannot keep winding up) and the autodriller keeps the WOB."""
    series = run_timeline('rpm_ramp')
    twin = series['twin']
    for label, m in _step_windows(series, 20.0):
        assert series['bit_angular_speed_rad_s'][m].mean() == pytest.approx(
            series['surface_speed_rad_s'][m].mean(), rel=0.01), label
        inferred = twin.string_weight_N - series['hook_load_N'][m]
        assert inferred.mean() == pytest.approx(60.5e3, rel=0.01), label
    assert series['surface_speed_rad_s'][-1] == pytest.approx(200 * 2 * math.pi / 60)


def test_block_actions_need_a_block(tmp_path):
    """Refused when the file is loaded, before the twin is built or a recording
    started."""
    path = tmp_path / 'no_block.yaml'
    path.write_text('configuration: benchmark_fem\nstart: drilling\n'
                    'steps:\n  - pick_up: {above_bottom_m: 1}\n')
    with pytest.raises(ScenarioError, match='needs a block') as err:
        run_timeline(path, out=tmp_path / 'run.mcap')
    assert str(path) in str(err.value) and 'model.axial_top=hoist' in str(err.value)
    assert not (tmp_path / 'run.mcap').exists()


def test_slack_off_beyond_the_string_weight_is_refused_with_the_weight(tmp_path):
    path = tmp_path / 'heavy.yaml'
    path.write_text('configuration: benchmark_fem\noverrides: [model.axial_top=hoist]\n'
                    'start: drilling\nsteps:\n  - slack_off: {wob_kN: 10000}\n')
    with pytest.raises(ScenarioError, match=r'10000 kN .* weighs in mud \(443.6 kN\)'):
        load_timeline(path)


def test_the_driller_checks_the_weight_of_the_twin_it_drives(tmp_path):
    """The twin node may hang the string in heavier mud than its configuration's: the
    driller refuses a slack-off beyond the weight of the twin it has, before a tick."""
    from drill_twin.config.scenario import load_scenario
    from drill_twin.operations.driller import Driller
    from drill_twin.runtime.digital_twin import DigitalTwin
    path = tmp_path / 'light.yaml'
    path.write_text('configuration: benchmark_fem\noverrides: [model.axial_top=hoist]\n'
                    'start: drilling\nsteps:\n  - slack_off: {wob_kN: 400}\n')
    timeline = load_timeline(path)                      # 443.6 kN in the configured mud
    twin = DigitalTwin(load_scenario('benchmark_fem', ['model.axial_top=hoist']),
                       mud_density_kg_m3=2500.0)
    with pytest.raises(ScenarioError, match=r'400 kN .* \(358.8 kN\)'):
        Driller(twin, timeline)


@pytest.mark.parametrize('text, words', [
    ('configuration: benchmark_fem\nsteps: []\n', 'non-empty'),
    ('configuration: benchmark_fem\nsteps:\n  - rotat: {rpm: 60}\n', 'did you mean rotate'),
    ('configuration: benchmark_fem\nsteps:\n  - rotate: {rpn: 60}\n', 'did you mean rpm'),
    ('configuration: benchmark_fem\nsteps:\n  - rotate: {rpm: -5}\n', 'rpm'),
    ('configuration: benchmark_fem\nsteps:\n  - rotate: {ramp_s: 5}\n', 'needs speed_rad_s'),
    ('configuration: benchmark_fem\nsteps:\n  - rotate: {rpm: 60, speed_rad_s: 6}\n',
     'not both'),
    ('configuration: benchmark_fem\nstart: sprint\nsteps:\n  - wait: {for_s: 1}\n', 'start'),
    ('configuration: benchmark_fem\nsteps:\n  - wait: 5\n', 'must map'),
    ('configurations: benchmark_fem\nsteps:\n  - wait: {for_s: 1}\n', 'did you mean'),
    ('steps:\n  - wait: {for_s: 1}\n', 'missing required key configuration'),
    ('configuration: benchmark_fem\nduration_s: 5\nsteps:\n  - wait: {for_s: 1}\n',
     'duration_s.*as long as its steps'),
    ('configuration: benchmark_fem\nstart: drilling\nbit_above_bottom_m: 1\n'
     'steps:\n  - wait: {for_s: 1}\n', 'start: rest only'),
    ('configuration: benchmark_fem\nrate_hz: 1000\nsteps:\n  - wait: {for_s: 1.0e+6}\n',
     r'for_s = 1000000.0 s: must be in \[0, 86400\] s'),
    ('configuration: benchmark_fem\nrate_hz: 1000\nsteps:\n  - wait: {for_s: 86400}\n'
     '  - wait: {for_s: 86400}\n', 'at most 1000000 ticks'),
    ('configuration: benchmark_fem\nsteps:\n  - rotate: {rpm: ' + '9' * 400 + '}\n',
     '400 digits, more than 19'),
    ('configuration: [benchmark_fem]\nsteps:\n  - wait: {for_s: 1}\n', 'name of a file'),
    ('configuration: benchmark_fem\noverrides: [model.axial_tpo=hoist]\n'
     'steps:\n  - wait: {for_s: 1}\n', 'did you mean model.axial_top'),
])
def test_scenario_file_errors_are_one_line(tmp_path, text, words):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(ConfigError, match=words) as err:
        load_timeline(path)
    assert '\n' not in str(err.value) and str(path) in str(err.value)


def test_rpm_alias_and_kn_alias_are_converted():
    steps = load_timeline('startup_from_rest').steps
    assert steps[0].params['speed_rad_s'] == pytest.approx(60 * 2 * math.pi / 60)
    assert steps[3].params['wob_N'] == pytest.approx(60.5e3)


def test_the_node_runs_a_scenario_records_it_and_restarts_it_on_request(rig, tmp_path):
    """twin_node with ``scenario``: built from the file (at rest), the timeline runs, the
    recording resimulates exactly; ``~/start_scenario`` starts it again; an operator
    set-point takes over."""
    pytest.importorskip('rclpy')
    from rclpy.parameter import Parameter
    from std_msgs.msg import Float64
    from std_srvs.srv import Trigger

    from drill_twin.ros.twin_node import TwinNode
    path = tmp_path / 'wob.yaml'
    path.write_text('configuration: benchmark_fem\noverrides: [model.axial_top=hoist]\n'
                    'start: rest\nbit_above_bottom_m: 0.2\nrate_hz: 50\nsteps:\n'
                    '  - rotate: {rpm: 60, ramp_s: 2}\n  - tag_bottom: {speed_m_s: 0.1}\n'
                    '  - slack_off: {wob_kN: 30, ramp_s: 2}\n  - drill: {for_s: 3}\n')
    record = tmp_path / 'node.mcap'
    node = rig.add(TwinNode(context=rig.ctx, parameter_overrides=[
        Parameter('scenario', value=str(path)), Parameter('as_fast_as_possible', value=True),
        Parameter('publish_rate_hz', value=50.0), Parameter('stability_period_s', value=0.0),
        Parameter('record_path', value=str(record))]))
    assert node.twin.peek()['bit_above_bottom_m'] == pytest.approx(0.2)
    assert rig.spin_until(lambda: node.driller.done, 120)
    offline = run_timeline(path)    # the same run: tagging bottom at 0.1 m/s bounces hard
    assert node.twin.peek()['hook_load_N'] == pytest.approx(offline['hook_load_N'][-1],
                                                            rel=1e-9)
    assert rig.call(Trigger, '/drill_twin/start_scenario', Trigger.Request()).success
    assert rig.spin_until(lambda: node.driller is not None and not node.driller.done, 10)
    rig.publisher('surface_speed_setpoint').publish(Float64(data=5.0))
    assert rig.spin_until(lambda: node.driller is None, 10)      # the operator took over
    assert rig.spin_until(lambda: node.twin.surface_speed_setpoint == 5.0, 10)
    rig.ex.remove_node(node)
    rig.nodes.remove(node)
    node.destroy_node()
    report = resimulate(open_recording(record))
    assert max(v['max_abs_difference'] for v in report['topics'].values()) == 0.0, \
        {k: v for k, v in report['topics'].items() if v['max_abs_difference']}


#: the rate of the node-vs-offline runs [Hz]: the files' 50-100 Hz cost the node ~2 ms a
#: tick (its topics and recording), 13,000 ticks for rpm_ramp; at 10 Hz the same code —
#: session, driller, recorder — runs a fifth of the ticks, and every shipped timeline
#: still reaches its end through the same steps (its log equal to the file's own rate's)
EQUALITY_RATE_HZ = 10.0


def _at_rate(name, rate_hz, tmp_path):
    """A copy of the shipped scenario ``name`` ticking at ``rate_hz`` (its path)."""
    text = (CONFIG_DIR / 'operations' / f'{name}.yaml').read_text()
    lines = [f'rate_hz: {rate_hz:g}' if line.startswith('rate_hz:') else line
             for line in text.splitlines()]
    path = tmp_path / f'{name}.yaml'
    path.write_text('\n'.join(lines) + '\n')
    return path


@pytest.mark.slow
@pytest.mark.parametrize('name', SHIPPED)
def test_a_shipped_scenario_runs_the_same_in_the_node_and_offline(rig, tmp_path, name):
    """``twin_node -p scenario:=FILE`` (unpaced) runs the timeline to its end, records it,
    and ends where ``drill-twin scenario run FILE`` ends: the same twin, driller and ticks
    (each shipped file at :data:`EQUALITY_RATE_HZ`)."""
    pytest.importorskip('rclpy')
    from rclpy.parameter import Parameter

    from drill_twin.ros.twin_node import TwinNode
    path = _at_rate(name, EQUALITY_RATE_HZ, tmp_path)
    timeline = load_timeline(path)
    assert timeline.rate_hz == EQUALITY_RATE_HZ
    offline = run_timeline(timeline)
    shipped = run_timeline(load_timeline(name))
    assert [label for _, label in offline['log']] == [label for _, label in shipped['log']]
    record = tmp_path / f'{name}.mcap'
    node = rig.add(TwinNode(context=rig.ctx, parameter_overrides=[
        Parameter('scenario', value=str(path)), Parameter('as_fast_as_possible', value=True),
        Parameter('publish_rate_hz', value=float(timeline.rate_hz)),
        Parameter('stability_period_s', value=0.0), Parameter('record_path', value=str(record))]))
    assert rig.spin_until(lambda: node.driller.done, 300)
    node_log = [label for _, label in node.driller.log]
    assert node_log == [label for _, label in offline['log']]
    end = offline['time_s'][-1]
    assert rig.spin_until(lambda: node.twin.peek()['time_s'] >= end - 1e-9, 60)
    rig.ex.remove_node(node)
    rig.nodes.remove(node)
    node.destroy_node()
    rec = open_recording(record)
    applied = rec.message_counts.get('/block_velocity_setpoint', 0) \
        + rec.message_counts.get('/surface_speed_setpoint', 0)
    assert applied >= len(timeline.steps)
    assert rec.message_counts['/bit/velocity'] >= 0.99 * end * EQUALITY_RATE_HZ
    decode = rec.decoder('/bit/velocity')
    samples = [(t * 1e-9, decode(data)) for _, t, data in rec.messages(['/bit/velocity'])]
    # log time = simulated time: the node's sample at the offline run's last instant is the
    # offline run's last sample
    t, msg = min(samples, key=lambda s: abs(s[0] - end))
    assert t == pytest.approx(end, abs=1e-6)
    assert msg.twist.angular.x == pytest.approx(offline['bit_angular_speed_rad_s'][-1],
                                                rel=1e-9, abs=1e-9)
