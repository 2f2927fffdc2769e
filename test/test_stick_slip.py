"""Nonlinear behaviour: stick-slip, stick logic, step convergence, FEM benchmark phases.

References: thesis Fig. 5.1.5 / [52] (RGD, β = 0.3 stick-slip with the bit speed
between 0 and about 2ω_o; β = 1.3 no stick-slip), Fig. 5.1.3 (RGD-2 oscillators
in phase), Figs 3.3.2-3.3.3 (FEM benchmark: axial stick first, growing angular
oscillations, angular stick-slip; slower angular growth with Soft-Torque).
"""
import numpy as np
import pytest

from drill_twin.analysis.statistics import stick_slip_summary
from drill_twin.config.scenario import load_scenario
from drill_twin.physics.models import fem_drill_string
from drill_twin.physics.simulation import Simulation, SimulationDiverged
from drill_twin.runtime.offline import run_scenario


@pytest.fixture(scope='module')
def rgd_runs():
    out = {}
    for beta in (0.3, 1.3):
        sc = load_scenario('rgd_stick_slip', [f'groups.beta={beta}'])
        out[beta] = run_scenario(sc, duration=300.0)[0]
    return out


def test_rgd_beta_03_stick_slip(rgd_runs):
    s = stick_slip_summary(rgd_runs[0.3], 100.0)
    assert s['bit_speed_min'] == 0.0 and s['stick_fraction'] > 0
    assert 1.6 * 5.0 < s['bit_speed_max'] < 2.4 * 5.0   # ~2 ω_o (Fig. 5.1.5a)


def test_rgd_beta_13_no_stick_slip(rgd_runs):
    s = stick_slip_summary(rgd_runs[1.3], 50.0)
    assert s['stick_fraction'] == 0.0 and s['first_angular_stick'] is None
    assert 0.8 * 5.0 < s['bit_speed_min'] and s['bit_speed_max'] < 1.2 * 5.0  # Fig. 5.1.5c


def test_no_backward_rotation_and_exact_stick(rgd_runs):
    s = rgd_runs[0.3]
    assert s['bit_angular_speed'].min() >= 0.0
    stuck = s['angular_stick'] > 0.5
    assert stuck.any()
    # held by the constraint: exactly zero speed, not a small threshold value
    assert np.all(s['bit_angular_speed'][stuck] == 0.0)
    assert np.all(s['bit_axial_speed'][stuck] <= 0.0)  # no drilling while stuck


@pytest.mark.parametrize('config, duration, stats_from, steps', [
    ('rgd_stick_slip', 400.0, 100.0, (0.002, 0.001)),
    # FEM: on the developed limit cycle (the transient before ~600 s is chaotic)
    pytest.param('benchmark_fem', 6000.0, 800.0, (0.005, 0.0025), marks=pytest.mark.slow),
])
def test_halving_the_step_changes_statistics_below_one_percent(config, duration, stats_from,
                                                               steps):
    stats = []
    for h in steps:
        sc = load_scenario(config, [f'simulation.time_step={h}'])
        stats.append(stick_slip_summary(run_scenario(sc, duration=duration)[0], stats_from))
    for key in ('stick_fraction', 'bit_speed_max', 'rop_mean', 'bit_speed_mean'):
        assert stats[1][key] == pytest.approx(stats[0][key], rel=0.01), key
    assert stats[0]['stick_fraction'] > 0


@pytest.fixture(scope='module')
def fem_runs():
    out = {}
    for drive in ('speed', 'soft_torque'):
        sc = load_scenario('benchmark_fem', [f'model.top_drive={drive}'])
        out[drive] = run_scenario(sc, duration=200.0 / sc.scales.time_s)[0]
    return out


def _first(series, mask):
    return float(series['time'][np.argmax(mask)]) if mask.any() else np.inf


def _angular_amplitude(series, t0, t1):
    w = (series['time'] >= t0) & (series['time'] < t1)
    om = series['bit_angular_speed'][w]
    return om.max() - om.min()


def test_fem_benchmark_three_phases(fem_runs):
    s = fem_runs['speed']
    t_axial = _first(s, s['axial_mode'] == 2)
    t_angular = _first(s, s['angular_stick'] > 0.5)
    assert t_axial < t_angular < np.inf          # (i) axial stick before (iii) angular stick
    amps = [_angular_amplitude(s, t, t + 20.0) for t in (20.0, 60.0, 100.0, 140.0)]
    assert all(b > a for a, b in zip(amps, amps[1:]))   # (ii) growing angular oscillation
    assert s['bit_angular_speed'].min() == 0.0


def test_soft_torque_slows_angular_growth(fem_runs):
    plain, st = fem_runs['speed'], fem_runs['soft_torque']
    assert _first(st, st['axial_mode'] == 2) < 30.0      # fast axial growth still happens
    assert _first(st, st['angular_stick'] > 0.5) > _first(plain, plain['angular_stick'] > 0.5)
    assert _angular_amplitude(st, 120.0, 160.0) < _angular_amplitude(plain, 120.0, 160.0)


def test_delay_residual_is_small_in_stick_slip(fem_runs):
    g = load_scenario('benchmark_fem').groups
    blade = 2 * np.pi / g.n_b
    for s in fem_runs.values():
        assert np.abs(s['delay_residual']).max() < 1e-6 * blade


def test_rgd2_oscillators_in_phase():
    sc = load_scenario('rgd2_stick_slip')
    sim = Simulation(sc.model, sc.groups, sc.time_step)
    sim.perturb(**sc.initial_perturbation)
    tr = sim.run(150.0, 0.01, record_state=True)
    w = tr.tau > 50
    phi = tr.state[w, 4:6]        # φ_top, φ_bottom (perturbations)
    assert np.corrcoef(phi.T)[0, 1] > 0.9                       # Fig. 5.1.3b
    assert tr.bit_angular_speed[w].min() == 0.0                 # stick-slip like RGD


def test_non_finite_state_stops_with_time_and_place():
    sc = load_scenario('rgd_stick_slip')
    sim = Simulation(sc.model, sc.groups, sc.time_step)
    sim.run(1.0, 0.1)
    sim.x[0] = np.nan
    with pytest.raises(SimulationDiverged, match=r'tau = .* in u\[0\]'):
        sim.run(1.0, 0.1)


def test_forward_euler_is_marginal_and_rk4_stable_at_the_default_step():
    """Delay-free FEM operator: |1 + hμ| (forward Euler, Δτ = 1e-4 of §3.3) vs the RK4
    stability function at the default Δτ = 5e-3 (eigenvalues from numpy, independent)."""
    sc = load_scenario('benchmark_fem')
    model = fem_drill_string(sc.system)
    mus = []
    for chain in (model.axial, model.torsional):
        Minv = np.linalg.inv(chain.dense('mass'))
        n = chain.n
        A = np.block([[np.zeros((n, n)), np.eye(n)],
                      [-Minv @ chain.dense('stiffness'), -Minv @ chain.dense('damping')]])
        mus.append(np.linalg.eigvals(A))
    mu = np.concatenate(mus)
    euler = np.abs(1 + 1e-4 * mu).max()
    z = sc.time_step * mu
    rk4 = np.abs(1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24).max()
    assert euler > 1.0 and euler - 1.0 < 1e-3      # marginal: slowly amplifying modes
    assert rk4 <= 1.0 + 1e-6   # = 1 only for the rigid-body mode μ = 0 (free axial top)


@pytest.mark.parametrize('n, ab, expect', [
    (2, (6.9, 2.96), 'in'), (2, (3.45, 2.96), 'anti'),
    (3, (6.9, 2.96), 'in'), (3, (3.45, 2.96), 'anti'),
    (10, (6.9, 2.96), 'in'), (10, (3.45, 2.96), 'anti')])
def test_axial_chain_phase_locking(n, ab, expect):
    """Figs 4.2.5, 4.3.2, 4.4.1: in phase far from the origin, out of phase near a = b."""
    a, b = ab
    sc = load_scenario('axial_chain_2dof', [f'model.n={n}', f'model.eps={0.5 if n == 2 else 1 / n}',
                                            f'groups.a={a}', f'groups.b={b}'])
    sim = Simulation(sc.model, sc.groups, sc.time_step)
    sim.perturb(u=1e-9)
    tr = sim.run(30.0, 0.01, record_state=True)
    assert sim.event_count == 0
    U = tr.state[tr.tau > 20, :n]
    c = np.corrcoef(U.T)
    if expect == 'in':
        assert c.min() > 0.9
    else:
        assert c.min() < -0.85


def test_unstable_time_step_is_rejected_and_auto_is_stable():
    """A step outside the RK4 region of the FEM's fastest mode is refused (it would chatter
    through thousands of spurious events); ``time_step: auto`` picks 80 % of the limit."""
    from drill_twin.errors import ParameterError
    with pytest.raises(ParameterError, match='RK4 stability region'):
        sc = load_scenario('benchmark_fem', ['model.elements=512', 'model.bha_elements=85'])
        Simulation(sc.model, sc.groups, sc.time_step)
    sc = load_scenario('benchmark_fem', ['model.elements=512', 'model.bha_elements=85',
                                         'simulation.time_step=auto',
                                         'simulation.reduction=none'])   # the full chain
    assert sc.time_step < 5e-3
    sim = Simulation(sc.model, sc.groups, sc.time_step)
    sim.perturb(where='smooth', **sc.initial_perturbation)
    sim.run(2.0, 0.1)
    assert sim.event_count < 50


def test_forward_euler_simulates_the_damping_theta_minus_h():
    """|1 + hμ|² = 1 + hω²(h − ϑ) exactly for stiffness-proportional damping (docs/physics.md),
    checked on the benchmark's torsional chain (numpy eigenvalues and eigen-frequencies,
    independent of the kernel): at the thesis's h = ϑ_φ = 1e-4 every torsional mode is
    undamped under Euler."""
    sc = load_scenario('benchmark_fem')
    tors = fem_drill_string(sc.system, theta_phi=1e-4).torsional
    M, K = tors.dense('mass'), tors.dense('stiffness')
    omega2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
    n = tors.n
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, tors.dense('damping'))]])
    mu = np.linalg.eigvals(A)
    for h in (1e-4, 5e-5):
        factor = np.sort(np.abs(1 + h * mu) ** 2)
        expected = np.sort(np.repeat(1 + h * omega2 * (h - 1e-4), 2))
        assert np.allclose(factor, expected, rtol=0, atol=1e-10)
    assert np.allclose(np.abs(1 + 1e-4 * mu) ** 2, 1.0, atol=1e-10)


@pytest.mark.parametrize('config, overrides', [
    ('rgd_stick_slip', []), ('benchmark_fem', []),
    ('benchmark_fem', ['model.elements=256', 'model.bha_elements=43',
                       'simulation.time_step=auto']),
    ('rig_fem', [])])
def test_recorded_rows_equal_a_fresh_evaluation_of_the_state(config, overrides):
    """The kernel records a step from the forces its last right-hand side left (no second
    evaluation): through stick-slip events, every recorded row equals the row that
    ``snapshot`` evaluates afresh from the same state (the delay residual aside, a
    Newton residual ~1e-11)."""
    from drill_twin.physics.kernel import RECORD_CHANNELS
    sc = load_scenario(config, overrides)
    sim = Simulation.from_scenario(sc)
    steps = int(60.0 / sc.time_unit_s / sc.time_step) if sc.is_si else int(60.0 / sc.time_step)
    for _ in range(40):
        traj = sim.advance(steps // 40, record_every=steps // 40)
        fresh = sim.snapshot()
        for i, name in enumerate(RECORD_CHANNELS):
            if name != 'delay_residual':
                assert traj.data[-1, i] == pytest.approx(fresh[name], rel=1e-12, abs=1e-12), name
    assert sim.event_count > 0
