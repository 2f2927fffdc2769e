"""drill-twin well: the torque-and-drag statics of a configuration on its well path.

Reference values are closed forms: in a vertical well the wall carries nothing, so every
hook load is the buoyed string weight Σ ρ g A_i L_i (1 − ρ_mud/ρ) whatever the friction
factor, the off-bottom torque is zero and on bottom the hook load drops by the WOB and
the surface torque is the torque on bit.  A deviated survey then parts the broomstick:
pick-up above rotating above slack-off, more so with more friction.  Round-off: a sum
of a few hundred RK4 stages of magnitude W, so 1e-9 relative."""
import json
import math

import numpy as np
import pytest

from drill_twin.cli import main
from drill_twin.config.scenario import load_scenario
from drill_twin.config.well import read_survey, resolve_survey, scenario_well
from drill_twin.physics.parameters import GRAVITY_M_S2


def _buoyed_weight_N(system):
    total = 0.0
    for sec in system.sections:
        area = math.pi / 4 * (sec.outer_diameter_m ** 2 - sec.inner_diameter_m ** 2)
        total += sec.density_kg_m3 * GRAVITY_M_S2 * area * sec.length_m * (
            1 - system.mud_density_kg_m3 / sec.density_kg_m3)
    return total


def test_a_vertical_well_has_no_drag_and_no_wall_torque(tmp_path, capsys):
    sc = load_scenario('benchmark_fem')
    weight = _buoyed_weight_N(sc.system)
    assert main(['well', '--config', 'benchmark_fem', '--out', str(tmp_path), '--json']) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ('pick_up_hook_load_N', 'slack_off_hook_load_N'):
        assert out[key] == pytest.approx([weight] * 4, rel=1e-9)
    assert out['rotating_hook_load_N'] == pytest.approx(weight, rel=1e-9)
    assert abs(out['surface_torque_off_bottom_Nm']) < 1e-9 * weight
    wob = sc.groups.W_o * sc.scales.force_N
    tob = sc.groups.T_o * sc.scales.torque_Nm
    assert out['hook_load_on_bottom_N'] == pytest.approx(weight - wob, rel=1e-9)
    assert out['surface_torque_on_bottom_Nm'] == pytest.approx(tob, rel=1e-9)
    assert all((tmp_path / name).stat().st_size > 10_000
               for name in ('broomstick.png', 'torque_profile.png'))


def test_a_deviated_well_parts_the_broomstick(tmp_path, capsys):
    assert main(['well', '--config', 'benchmark_fem', '--set', 'well.survey=j_well',
                 '--out', str(tmp_path), '--json']) == 0
    out = json.loads(capsys.readouterr().out)
    up, down = np.array(out['pick_up_hook_load_N']), np.array(out['slack_off_hook_load_N'])
    rot = out['rotating_hook_load_N']
    assert np.all(np.diff(up) > 0) and np.all(np.diff(down) < 0)      # more μ, more drag
    assert np.all(up > rot) and np.all(down < rot)
    assert out['surface_torque_off_bottom_Nm'] > 1000.0                # the wall's torque


def test_shipped_surveys_are_found_by_name_and_are_what_they_say():
    well_b = read_survey(resolve_survey('well_b'))
    md = np.array([0.0, 400.0, 500.0, 1050.0, 1600.0, 2500.0])
    assert np.degrees(well_b.inclination(md)) == pytest.approx([0, 0, 0, 30, 60, 60],
                                                                abs=1e-9)
    j_well = read_survey(resolve_survey('j_well.csv'))
    assert np.degrees(j_well.inclination(np.array([300.0, 750.0, 2000.0]))) == \
        pytest.approx([0, 45, 45], abs=1e-9)
    # no survey: the vertical well to the string's length
    sc = load_scenario('benchmark_fem')
    vertical = scenario_well(sc)
    assert vertical.total_depth_m == sc.system.total_length_m
    assert np.all(vertical.inclination(np.array([0.0, 600.0, 1200.0])) == 0.0)
