"""The motor top drive and its controller modes (docs/control.md).

Reference values: the thesis's ideal Soft-Torque drive (§3.2, an independent model of the
same closed loop), the growth rates of the nonlinear simulation (the linearisation is the
code under test), the analytic characteristic impedance of the pipe ``J sqrt(G ρ)`` and the
d'Alembert split of a wave into its travelling parts.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import eigenvector_state, measured_growth_rate, roundoff_bound

from drill_twin.config.scenario import load_scenario
from drill_twin.control.tuning import closed_loop_score, tune_gains
from drill_twin.physics.simulation import Simulation
from drill_twin.physics.top_drive import (
    mode_gains,
    pipe_torsional_impedance,
    reflection_coefficient,
)
from drill_twin.stability.linearize import linearize
from drill_twin.stability.spectrum import rightmost_roots

MOTOR = ['model.top_drive=motor']


def test_motor_drive_with_soft_torque_gains_is_the_thesis_soft_torque_drive():
    """Below its torque limit, without delay and torque feedback, the PI loop on the motor
    inertia is the spring k_f and dash-pot c_f of §3.2: the two models run the same
    trajectory (to rounding) through 300 t* of drilling."""
    runs = []
    for ov in (['model.top_drive=soft_torque'], MOTOR + ['drive.controller=soft_torque']):
        sim = Simulation.from_scenario(load_scenario('benchmark_fem', ov),
                                       perturbation={'u': 0.01, 'v': 0.01, 'omega': 0.1})
        runs.append(sim.run(300.0, 0.5))
    # the same equations in two arithmetic orders: round-off only, 60000 steps of a drive
    # that makes the steady state stable (no growth): roundoff_bound(60000) = 1.3e-11, so
    # 1e-9 holds with 75x to spare (the kernel's arithmetic is the same on every CPU)
    assert 1e-9 > roundoff_bound(int(300.0 / 5e-3))
    for ch in ('bit_angular_speed', 'weight_on_bit', 'surface_torque', 'top_drive_speed',
               'motor_torque'):
        a, b = getattr(runs[0], ch), getattr(runs[1], ch)
        assert np.max(np.abs(a - b)) < 1e-9 * np.max(np.abs(a)), ch


def _drive_root(dde, model, roots):
    """The unstable root whose mode moves the motor most (largest motor-speed component
    relative to the mode's largest entry), and that component."""
    w0 = 2 * model.axial.n + model.torsional.n
    best, weight = None, -1.0
    for r in roots:
        if r.imag <= 0 or r.real < 0.05:   # fast enough to measure before the others grow
            continue
        v = np.linalg.svd(dde.characteristic_matrix(r))[2][-1]
        share = abs(v[w0]) / np.max(np.abs(v))
        if share > weight:
            best, weight = r, share
    return best, weight


MODES = {
    'stiff_pi': ['drive.controller=stiff_pi'],
    'soft_torque': ['drive.controller=soft_torque'],
    'z_torque': ['drive.controller=z_torque'],
    'z_torque, 5 ms sensor delay': ['drive.controller=z_torque', 'drive.sensor_delay_s=0.005'],
    'stability_tuned': ['drive.controller=stability_tuned'],
}


@pytest.mark.timeout(900)
@pytest.mark.parametrize('mode', list(MODES))
def test_closed_loop_linearisation_matches_the_nonlinear_growth_rate(mode):
    """Each controller's closed loop, linearised (drive states included, the sensor delay as
    delayed terms), predicts the early growth of its own nonlinear simulation started along
    the root's mode, within 2 %: for the dominant root, and for the unstable root that moves
    the motor most."""
    sc = load_scenario('benchmark_fem', MOTOR + ['model.elements=20', 'model.bha_elements=4']
                       + MODES[mode])
    dde = linearize(sc.model, sc.groups)
    roots = rightmost_roots(dde, count=30).roots
    drive_root, weight = _drive_root(dde, sc.model, roots)
    checks = [roots[0]] + ([drive_root] if drive_root is not None and weight > 0.1
                           and abs(drive_root - roots[0]) > 1e-6 else [])
    if mode.endswith('delay'):
        assert len(checks) == 2     # the delayed loop has an unstable mode of its own
    for root in checks:
        period = 2 * math.pi / root.imag
        window = (10 * period, 10 * period + min(4.0 / root.real, 60.0))
        y0, _ = eigenvector_state(sc.model, sc.groups, root, 1e-8)
        assert y0.size == 2 * (sc.model.axial.n + sc.model.torsional.n) + 2
        rate = measured_growth_rate(sc.model, sc.groups, root, window, h=1e-3)
        assert rate == pytest.approx(root.real, rel=0.02), (mode, root)


def test_z_torque_impedance_matches_the_pipe_in_the_band_of_the_first_three_modes():
    """The analytic drive impedance: Z-Torque reflects < 10 % of a wave's energy between
    the first and the third torsional mode of the string (and a stiff PI loop nearly all
    of it), the pipe's impedance being J sqrt(G ρ) from the section data."""
    sc = load_scenario('rig_fem', ['drive.controller=z_torque'])
    z = pipe_torsional_impedance(sc.system)
    ds = sc.raw['drill_string']
    polar = math.pi / 2 * (ds['pipe_outer_radius_m'] ** 4 - ds['pipe_inner_radius_m'] ** 4)
    assert z == pytest.approx(polar * math.sqrt(ds['shear_modulus_Pa'] * ds['density_kg_m3']))
    roots = rightmost_roots(load_scenario('benchmark_fem').model, sc.groups, count=40).roots
    modes = np.sort(np.abs(roots.imag[roots.imag > 0]))[:3] / sc.scales.time_s
    band = np.linspace(0.5 * modes[0], 1.2 * modes[2], 200)
    zt = sc.model.top_drive
    stiff = load_scenario('rig_fem').model.top_drive
    assert max(abs(reflection_coefficient(w, zt, z)) ** 2 for w in band) < 0.1
    assert min(abs(reflection_coefficient(w, stiff, z)) ** 2 for w in band) > 0.8


def _travelling_parts(traj, model, scales, z_si, node):
    """Up- and down-going angular speeds at ``node`` (d'Alembert: T = Z(ω_d - ω_u))."""
    na, nt = model.axial.n, model.torsional.n
    tr = model.torsional
    k, c = -tr.stiffness[2, node], -tr.damping[2, node]
    phi = traj.state[:, 2 * na: 2 * na + nt]
    om = traj.state[:, 2 * na + nt: 2 * na + 2 * nt]
    torque = (k * (phi[:, node] - phi[:, node + 1]) + c * (om[:, node] - om[:, node + 1]))
    z = z_si / (scales.time_s * scales.torque_Nm)       # N m s/rad -> C t*
    w = 0.5 * (om[:, node] + om[:, node + 1])
    return 0.5 * (w - torque / z), 0.5 * (w + torque / z)


@pytest.mark.parametrize('controller, bound', [('z_torque', (0.0, 0.1)),
                                               ('stiff_pi', (0.8, 1.01))])
def test_a_torsional_pulse_travelling_up_the_pipe_is_absorbed_by_z_torque(controller, bound):
    """Time domain, the twin's own string: a pulse travelling up a 6 km pipe (spectrum
    within the band of the first three torsional modes of the benchmark) meets the drive;
    the energy that comes back down, measured by the d'Alembert split half-way, is < 10 %
    of the incident energy with Z-Torque, > 80 % with the stiff loop."""
    sc = load_scenario('rig_fem', [f'drive.controller={controller}',
                                   'drill_string.pipe_length_m=6000', 'model.elements=600',
                                   'model.bha_elements=20', 'simulation.time_step=auto',
                                   'simulation.reduction=none'])   # the full chain's nodes
    model, s = sc.model, sc.scales
    sim = Simulation(model, sc.groups, sc.time_step)
    nt = model.torsional.n
    x = np.concatenate([[0.0], np.cumsum(model.element_lengths_m)])[:nt]
    c_wave = math.sqrt(sc.system.sections[0].shear_modulus_Pa
                       / sc.system.sections[0].density_kg_m3)
    sigma = 400.0                                   # m: energy e^{-(ω σ/c)²}, < e^{-10} at 25 rad/s
    phi = 1e-3 * np.exp(-0.5 * ((x - 3000.0) / sigma) ** 2)
    # up-going wave φ = F(t + x/c): ω = c ∂φ/∂x  (per t*)
    omega = c_wave * np.gradient(phi, x) * s.time_s
    y = np.zeros(2 * (model.axial.n + nt) + 2)
    na = model.axial.n
    y[2 * na:2 * na + nt] = phi
    y[2 * na + nt:2 * na + 2 * nt] = omega
    sim.set_perturbation_state(y)
    duration = 2.2 * 3000.0 / c_wave / s.time_s      # to the top and back past half-way
    traj = sim.run(duration, sc.time_step, record_state=True)
    node = int(np.argmin(np.abs(x - 1500.0)))
    up, down = _travelling_parts(traj, model, s, pipe_torsional_impedance(sc.system), node)
    ratio = float(np.sum(down ** 2) / np.sum(up ** 2))
    assert bound[0] <= ratio < bound[1]


@pytest.mark.timeout(900)
@pytest.mark.slow
def test_stability_tuned_gains_beat_soft_torque_at_the_benchmark_point():
    """At the benchmark point the tuned gains score below the Soft-Torque tuning (the
    spectral abscissa plus the growth of every unstable root) without raising the
    abscissa (set by a coupled axial-torsional mode no top boundary moves), and the
    nonlinear run agrees: stick-slip sets in later than with Soft-Torque, or not at all."""
    st = load_scenario('rig_fem', ['drive.controller=soft_torque'])
    gains, report = tune_gains(st.model, st.groups, st.system)
    assert report['tuned_score'] < report['soft_torque_score'] - 1e-3
    assert report['tuned_abscissa'] <= report['soft_torque_abscissa'] + 1e-4
    tuned = load_scenario('rig_fem', ['drive.controller=soft_torque',
                                      f'drive.proportional_gain_Nms_rad={gains.proportional_Nms_rad}',
                                      f'drive.integral_gain_Nm_rad={gains.integral_Nm_rad}',
                                      f'drive.torque_feedback_rad_s_Nm={gains.torque_feedback_rad_s_Nm}'])
    # the gains went through '%r' text and back (exact), the score is an eigenvalue problem
    # (LAPACK: CPU-dependent round-off ~ κ ε ~ 1e-12); 1e-6 is the optimiser's tolerance
    assert closed_loop_score(tuned.model, tuned.groups)['score'] == pytest.approx(
        report['tuned_score'], rel=1e-6)

    def onset(sc):
        traj = Simulation.from_scenario(sc).run(600.0 / sc.scales.time_s,
                                                0.01 / sc.scales.time_s)
        stuck = traj.angular_stick > 0
        return traj.tau[np.argmax(stuck)] if stuck.any() else math.inf
    t_st, t_tuned = onset(st), onset(tuned)
    assert t_st < math.inf and t_tuned > t_st


def test_mode_gains_follow_their_definitions():
    """stiff PI: critically damped loop of bandwidth ω_c on J; Soft-Torque: k = J/t*²,
    c = 2 ξ sqrt(k J), ξ = sqrt(I/(2J)); Z-Torque: g_T = 1/Z."""
    sc = load_scenario('rig_fem')
    J, s = 5000.0, sc.scales
    pi = mode_gains('stiff_pi', sc.system, J, 20.0)
    assert (pi.proportional_Nms_rad, pi.integral_Nm_rad) == pytest.approx((2e5, 2e6))
    st = mode_gains('soft_torque', sc.system, J, 20.0)
    k = J / s.time_s ** 2
    assert st.integral_Nm_rad == pytest.approx(k)
    assert st.proportional_Nms_rad == pytest.approx(
        2 * math.sqrt(s.inertia_kgm2 / (2 * J)) * math.sqrt(k * J))
    zt = mode_gains('z_torque', sc.system, J, 20.0)
    assert zt.torque_feedback_rad_s_Nm == pytest.approx(1 / pipe_torsional_impedance(sc.system))


def test_torque_limit_holds_and_the_integral_does_not_wind_up():
    """A set-point step the motor cannot follow at once: the motor torque stays within its
    limit, and once the speed is reached the overshoot is that of the unsaturated loop
    (back-calculation: no wind-up)."""
    out = {}
    for limit in (8e3, 1e7):
        sc = load_scenario('rig_fem', [f'drive.torque_limit_Nm={limit}'])
        sim = Simulation.from_scenario(sc, perturbation={})
        sim.set_surface_speed(1.3 * sc.groups.omega_o)
        traj = sim.run(60.0, 0.01)
        out[limit] = traj
        torque_si = traj.motor_torque * sc.scales.torque_Nm
        # the clamp is exact in units of C; back in N·m one multiplication rounds (ε)
        assert np.max(np.abs(torque_si)) <= limit * (1 + 1e-12)
    limited, free = out[8e3], out[1e7]
    assert np.max(np.abs(limited.motor_torque * sc.scales.torque_Nm)) == pytest.approx(8e3)
    target = 1.3 * sc.groups.omega_o

    def overshoot(traj):
        return (np.max(traj.top_drive_speed) - target) / (0.3 * sc.groups.omega_o)
    assert overshoot(limited) < overshoot(free) + 0.1
