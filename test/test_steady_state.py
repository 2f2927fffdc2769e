"""Unperturbed runs stay on the steady state of eqs 2.3.6, 2.4.5, 2.4.6 (every model).

The reference values are computed here from the equations (δ_o = W_o/n_b - λ,
υ_o = n_b δ_o ω_o / 2π, T_o = n_b(δ_o + λβ), τ_1,0 = 2π/(n_b ω_o)), not taken
from the library.
"""
import math

import numpy as np
import pytest

from drill_twin.config.scenario import load_scenario
from drill_twin.physics.models import axial_chain, coupled_chain, rgd, rgd_k
from drill_twin.physics.parameters import BitRockGroups
from drill_twin.physics.simulation import Simulation

SETS = [dict(n_b=6, lam=5 / 6, beta=0.3, W_o=7.0, omega_o=5.0, psi=50.0),
        dict(n_b=4, lam=0.5, beta=1.3, W_o=3.1, omega_o=11.0, psi=13.79),
        dict(n_b=1, lam=0.0, beta=0.0, W_o=1.0, omega_o=2 * math.pi, psi=2.96)]


def _models(p):
    return [rgd(p['psi']), rgd_k(p['psi'], 2.5), axial_chain(3, 4.0, p['psi'], eps=0.2),
            coupled_chain(2, 2.5, p['psi'])]


@pytest.mark.parametrize('p', SETS)
def test_steady_state_is_reproduced(p):
    g = BitRockGroups(**p)
    delta_o = p['W_o'] / p['n_b'] - p['lam']
    ups = p['n_b'] * delta_o * p['omega_o'] / (2 * math.pi)
    T_o = p['n_b'] * (delta_o + p['lam'] * p['beta'])
    for model in _models(p):
        sim = Simulation(model, g, 2e-3)
        tr = sim.run(3.0, 0.05)  # unstable equilibria: roundoff grows like e^{3 tau}
        assert np.allclose(tr.depth_of_cut, delta_o, atol=1e-9, rtol=0), model.name
        assert np.allclose(tr.bit_axial_speed, ups, atol=1e-9, rtol=0), model.name
        assert np.allclose(tr.bit_angular_speed, p['omega_o'], atol=1e-9, rtol=0)
        assert np.allclose(tr.weight_on_bit, p['W_o'], atol=1e-9, rtol=0)
        assert np.allclose(tr.torque_on_bit, T_o, atol=1e-9, rtol=0)
        assert np.allclose(tr.delay, 2 * math.pi / (p['n_b'] * p['omega_o']), atol=1e-9)


def test_fem_benchmark_steady_state():
    sc = load_scenario('benchmark_fem')
    g = sc.groups
    sim = Simulation(sc.model, g, sc.time_step)
    tr = sim.run(5.0, 0.05)
    delta_o = g.W_o / g.n_b - g.lam
    assert np.allclose(tr.depth_of_cut, delta_o, atol=1e-9)
    assert np.allclose(tr.surface_torque, g.n_b * (delta_o + g.lam * g.beta), atol=1e-9)
