"""The drill-twin command line: real runs, JSON outputs, clear errors (exit 2, no traceback)."""
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from drill_twin.cli import main


def run_cli(*args):
    proc = subprocess.run([sys.executable, '-m', 'drill_twin.cli', *args], capture_output=True,
                          text=True, timeout=300)
    return proc.returncode, proc.stdout, proc.stderr


def test_simulate_summary_json_and_output(tmp_path, capsys):
    out = tmp_path / 'run.npz'
    assert main(['simulate', '--config', 'rgd_stick_slip', '--tau', '200', '--stats-from',
                 '100', '--summary-json', '--out', str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    for key in ('first_angular_stick', 'stick_fraction', 'bit_speed_max', 'bit_speed_min',
                'bit_speed_mean', 'severity', 'rop_mean', 'delay_residual_max'):
        assert key in summary
    assert summary['bit_speed_min'] == 0.0 and summary['first_angular_stick'] >= 100
    data = np.load(out)
    assert data['time'][-1] == pytest.approx(200.0, abs=0.02)
    # severity is (max - min)/(2 mean) of the bit speed
    assert summary['severity'] == pytest.approx(
        (summary['bit_speed_max'] - summary['bit_speed_min']) / (2 * summary['bit_speed_mean']))


def test_simulate_si_units(capsys):
    assert main(['simulate', '--config', 'benchmark_fem', '--duration', '5',
                 '--summary-json']) == 0
    s = json.loads(capsys.readouterr().out)
    assert s['simulated'] == pytest.approx(5.0, abs=0.02)             # seconds
    assert s['bit_speed_mean'] == pytest.approx(12.57, rel=0.02)      # rad/s
    assert 0 < s['rop_mean'] < 0.01                                   # m/s


def test_params_derives_groups(capsys):
    assert main(['params', '--config', 'benchmark_fem', '--json']) == 0
    p = json.loads(capsys.readouterr().out)
    assert p['upsilon_o'] == pytest.approx(p['omega_o'] * (p['W_o'] - p['n_b_lambda'])
                                           / (2 * math.pi))
    assert p['t_star_s'] == pytest.approx(0.3, rel=0.01)


def test_stability_roots_json(capsys):
    assert main(['stability', 'roots', '--config', 'rgd_stick_slip', '--json']) == 0
    out = json.loads(capsys.readouterr().out)
    assert out['abscissa'] == pytest.approx(max(r[0] for r in out['roots']))


@pytest.mark.parametrize('args, message', [
    (['simulate', '--config', 'no_such_config'], 'no such configuration'),
    (['simulate', '--config', 'rgd_stick_slip', '--set', 'groups.W_o=2'], 'friction threshold'),
    (['simulate', '--config', 'rgd_stick_slip', '--set', 'groups.n_b=0'], 'n_b'),
    (['simulate', '--config', 'rgd_stick_slip', '--set', 'groups.psi=.nan'], 'psi'),
    (['simulate', '--config', 'benchmark_fem', '--set', 'drill_string.pipe_length_m=-3'],
     'pipe_length_m'),
    (['simulate', '--config', 'rgd_stick_slip', '--tau', '-1'], '--tau -1 t*'),
])
def test_bad_input_gives_clear_error(args, message):
    code, out, err = run_cli(*args)
    assert code == 2 and message in err and 'Traceback' not in err


def test_malformed_yaml(tmp_path):
    bad = tmp_path / 'x.yaml'
    bad.write_text('model: {type: rgd\n')
    code, _, err = run_cli('simulate', '--config', str(bad))
    assert code == 2 and 'malformed YAML' in err


def test_semi_infinite_is_stability_only(capsys):
    assert main(['stability', 'roots', '--config', 'benchmark_fem', '--set',
                 'model.type=semi_infinite', '--json']) == 0
    assert json.loads(capsys.readouterr().out)['abscissa_1_s'] < 0   # SI config: 1/s
    code, _, err = run_cli('simulate', '--config', 'benchmark_fem', '--set',
                           'model.type=semi_infinite')
    assert code == 2 and 'stability model only' in err


def test_discretization_study_small(tmp_path, capsys):
    png = tmp_path / 'd.png'
    assert main(['stability', 'discretization', '--config', 'benchmark_fem', '--sizes',
                 '32,64', '--out', str(png), '--json']) == 0
    table = json.loads(capsys.readouterr().out)
    damped = next(v for k, v in table.items() if k.startswith('FEM, Rayleigh'))
    # converged to 1 % between 32 and 64 elements (docs/discretization.md)
    assert damped['64'][0] == pytest.approx(damped['32'][0], rel=0.05)
    assert png.stat().st_size > 0


@pytest.mark.slow
def test_stability_gallery_quick(tmp_path):
    code, out, err = run_cli('stability', 'gallery', '--quick', '--out', str(tmp_path))
    assert code == 0, err
    for fig in ('4_1_2', '4_2_2', '4_3_1', '5_1_2', '5_2_2', 'B_3_1'):
        assert (tmp_path / f'fig_{fig}.png').stat().st_size > 0
    summary = json.loads((tmp_path / 'stability_gallery.json').read_text())
    assert summary['5.1.2 RGD-2, strict (Re λ > 1e-9)']['stable_fraction'] == 0.0


def test_params_in_field_units(capsys):
    """API field units (1 lbf = 4.4482216152605 N, 1 ft = 0.3048 m) of the benchmark point:
    120 rpm and 60.5 kN."""
    assert main(['params', '--config', 'benchmark_fem', '--json']) == 0
    p = json.loads(capsys.readouterr().out)
    f = p['field_units']
    assert f['surface_speed_rpm'] == pytest.approx(12.57 * 60 / (2 * math.pi), rel=1e-12)
    assert f['weight_on_bit_klbf'] == pytest.approx(60.5e3 / 4.4482216152605 / 1e3, rel=1e-9)
    assert f['rate_of_penetration_ft_h'] == pytest.approx(
        p['rate_of_penetration_m_s'] * 3600 / 0.3048, rel=1e-12)
    assert f['string_length_ft'] == pytest.approx(1200 / 0.3048)
