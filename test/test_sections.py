"""Drill strings from field data (issue 14): several sections, each with its own OD, ID,
length and material.  Every reference value here is computed independently from the
configuration's numbers (analytic statics, the transfer-matrix method of a continuous
multi-section shaft), never from the model under test."""
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from drill_twin.config.lookup import CONFIG_DIR
from drill_twin.config.scenario import load_scenario
from drill_twin.physics.parameters import GRAVITY_M_S2
from drill_twin.physics.simulation import Simulation
from drill_twin.physics.statics import element_tension_N, rest_state

FIELD = [  # drill pipe (steel), heavy-weight pipe, collars; aluminium pipe on top
    {'name': 'aluminium pipe', 'length_m': 600.0, 'outer_diameter_m': 0.147,
     'inner_diameter_m': 0.125, 'density_kg_m3': 2800.0, 'young_modulus_Pa': 70e9,
     'shear_modulus_Pa': 26e9},
    {'name': 'drill pipe', 'length_m': 1400.0, 'outer_diameter_m': 0.127,
     'inner_diameter_m': 0.1086},
    {'name': 'heavy-weight pipe', 'length_m': 140.0, 'outer_diameter_m': 0.127,
     'inner_diameter_m': 0.0762},
    {'name': 'collars', 'length_m': 120.0, 'outer_diameter_m': 0.1651,
     'inner_diameter_m': 0.0714, 'bha': True},
]
STEEL = {'density_kg_m3': 7850.0, 'young_modulus_Pa': 207e9, 'shear_modulus_Pa': 79.3e9}
MUD = 1300.0


def _config(tmp_path, extra=''):
    text = (CONFIG_DIR / 'benchmark_fem.yaml').read_text()
    lines = []
    skip = ('pipe_length_m', 'bha_length_m', 'pipe_outer_radius_m', 'pipe_inner_radius_m',
            'bha_outer_radius_m', 'bha_inner_radius_m', 'density_kg_m3', 'young_modulus_Pa',
            'shear_modulus_Pa', 'bha_elements')
    for line in text.splitlines():
        if line.strip().split(':')[0] in skip:
            continue
        lines.append(line)
        if line.startswith('drill_string:'):
            lines += [f'  {k}: {v}' for k, v in STEEL.items()]
            lines.append(f'  mud_density_kg_m3: {MUD}')
            lines.append('  sections:')
            for sec in FIELD:
                lines.append('    - {' + ', '.join(f'{k}: {v}' for k, v in sec.items()) + '}')
    path = tmp_path / 'field.yaml'
    path.write_text('\n'.join(lines) + '\n' + extra)
    return path


def _sections():
    out = []
    for sec in FIELD:
        full = {**STEEL, **sec}
        a = math.pi / 4 * (full['outer_diameter_m'] ** 2 - full['inner_diameter_m'] ** 2)
        j = math.pi / 32 * (full['outer_diameter_m'] ** 4 - full['inner_diameter_m'] ** 4)
        out.append({**full, 'A': a, 'J': j})
    return out


def test_scales_of_a_field_string(tmp_path):
    """t* from the collars' inertia and the pipe's series torsional stiffness (eq. 2.4.1)."""
    sc = load_scenario(_config(tmp_path), ['model.elements=120'])
    secs = _sections()
    inertia = secs[-1]['density_kg_m3'] * secs[-1]['J'] * secs[-1]['length_m']
    compliance = sum(s['length_m'] / (s['shear_modulus_Pa'] * s['J']) for s in secs[:-1])
    assert sc.scales.time_s == pytest.approx(math.sqrt(inertia * compliance), rel=1e-12)
    assert sc.scales.torque_Nm == pytest.approx(1 / compliance, rel=1e-12)
    assert sum(sc.model.section_elements) == 120 and min(sc.model.section_elements) >= 1


def test_hanging_string_has_the_analytic_tension(tmp_path):
    """At rest off bottom, and after 30 s of simulated hanging: the tension at the top of
    every element is the buoyed weight below it, section by section."""
    sc = load_scenario(_config(tmp_path, 'rig: {block_mass_kg: 25000}\n'),
                       ['model.elements=96', 'model.axial_top=hoist'])
    sim = Simulation.from_scenario(sc)
    rest_state(sim, 0.3 / sc.scales.depth_m)
    lengths = []
    for s, n in zip(_sections(), sc.model.section_elements):
        w = (s['density_kg_m3'] - MUD) * GRAVITY_M_S2 * s['A'] * s['length_m'] / n
        lengths += [w] * n
    below = np.cumsum(np.asarray(lengths)[::-1])[::-1]
    assert element_tension_N(sc, sim) == pytest.approx(below, rel=1e-9)
    sim.run(30.0 / sc.scales.time_s, record_interval=1.0)
    assert element_tension_N(sc, sim) == pytest.approx(below, rel=1e-6)
    assert sim.snapshot()['weight_on_bit'] == 0.0


def test_twist_of_a_stuck_bit_is_torque_times_the_section_compliances(tmp_path):
    """The bit held on the rock, the rotary turned slowly: the string winds up as a static
    shaft, twist = T Σ L/(G J) over every section (collars included)."""
    sc = load_scenario(_config(tmp_path), ['model.elements=96'])
    sim = Simulation.from_scenario(sc)
    rest_state(sim, 0.01 / sc.scales.depth_m)
    sim.set_axial_top_force(-0.5 * sc.groups.W_o)       # lower on the rock: W = W_o/2
    sim.run(60.0 / sc.scales.time_s, record_interval=1.0)
    assert sim.snapshot()['contact'] == 1.0
    t_star = sc.scales.time_s
    sim.set_surface_speed(0.02 * t_star)                 # 0.02 rad/s at the rotary
    compliance = sum(s['length_m'] / (s['shear_modulus_Pa'] * s['J']) for s in _sections())
    pairs = []
    for _ in range(400):
        sim.run(0.5 / t_star, record_interval=0.5 / t_star)
        snap = sim.snapshot()
        if snap['angular_stick'] < 0.5:
            break                                        # broken free
        # the state is a perturbation of steady drilling, whose string is twisted by the
        # nominal torque T_o: twist = θ_p - φ_bit + T_o Σ L/(G J)
        torque_o = sc.groups.T_o * sc.scales.torque_Nm
        twist = snap['top_angle_perturbation'] + sc.groups.omega_o * sim.time \
            - snap['bit_angle'] + torque_o * compliance
        torque = snap['surface_torque'] * sc.scales.torque_Nm
        pairs.append((torque, twist))
    torque, twist = np.array(pairs).T
    assert torque.max() > 300.0 and len(pairs) > 30     # wound up before breaking free
    slope, offset = np.polyfit(torque, twist, 1)       # the torsional waves average out
    assert slope == pytest.approx(compliance, rel=0.01)
    assert abs(offset) < 0.01 * twist.max()


def _transfer(omega, secs):
    """Transfer matrix [θ, T]_bottom = P [θ, T]_top of uniform shafts in series."""
    P = np.eye(2)
    for s in secs:
        c = math.sqrt(s['shear_modulus_Pa'] / s['density_kg_m3'])
        k = omega / c
        gjk = s['shear_modulus_Pa'] * s['J'] * k
        kl = k * s['length_m']
        P = np.array([[math.cos(kl), math.sin(kl) / gjk],
                      [-gjk * math.sin(kl), math.cos(kl)]]) @ P
    return P


def test_torsional_frequencies_equal_the_transfer_matrix_of_the_sections(tmp_path):
    """Top held by the speed drive, bit end free: the FEM's lowest frequencies against
    the roots of P_22(ω) = 0 of the continuous multi-section shaft."""
    sc = load_scenario(_config(tmp_path), ['model.elements=480', 'simulation.time_step=auto'])
    tors = sc.model.torsional
    omega2 = np.linalg.eigvals(np.linalg.solve(tors.dense('mass'), tors.dense('stiffness')))
    fem = np.sort(np.sqrt(omega2.real)) / sc.scales.time_s
    secs = _sections()
    grid = np.linspace(0.05, fem[3] * 1.1, 4000)
    values = [_transfer(w, secs)[1, 1] for w in grid]
    roots = [brentq(lambda w: _transfer(w, secs)[1, 1], a, b)
             for a, b, fa, fb in zip(grid[:-1], grid[1:], values[:-1], values[1:])
             if fa * fb < 0]
    assert len(roots) >= 3
    assert fem[:3] == pytest.approx(np.array(roots[:3]), rel=2e-3)
