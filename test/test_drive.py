"""Commanded surface inputs: speed drive dynamics, hook-load changes, semi-infinite limit.

References: the first-order drive lag ω(τ) = ω_1 + (ω_0 - ω_1) e^{-τ/T_d} (analytic);
the steady state eqs 2.4.5-2.4.6 at the new operating point; for the semi-infinite
pipe the decoupled axial equation u' = -k (u - u(τ-τ_0)) has no root with Re > 0
besides 0 (|λ + k| = k |e^{-λτ_0}| < k is impossible for Re λ > 0).
"""
import math

import numpy as np
import pytest

from drill_twin.errors import ParameterError
from drill_twin.physics.models import StringModel, lumped_chain, rgd
from drill_twin.physics.parameters import BitRockGroups
from drill_twin.physics.simulation import Simulation
from drill_twin.stability.linearize import linearize_semi_infinite
from drill_twin.stability.spectrum import rightmost_roots

# ψ = 2: ω_c = sqrt(8ψ/n_b) = 1.63 < ω_o, so the axial mode is stable; the torsional
# pendulum gets a dash-pot (1.0 > the anti-damping 2πυ_o/ω_o² = 0.42 of the delay)
QUIET = dict(n_b=6, lam=5 / 6, beta=1.3, W_o=7.0, omega_o=5.0, psi=2.0)


def damped_rgd(psi):
    return StringModel('damped_rgd', lumped_chain([1.0], [0.0], top_fixed=False),
                       lumped_chain([1.0], [1.0], damping=[1.0]), psi)


def test_speed_step_follows_drive_lag_and_bit_follows_surface():
    g = BitRockGroups(**QUIET)
    T_d = 0.5
    sim = Simulation(damped_rgd(g.psi), g, 2e-3, drive_time_constant=T_d)
    sim.run(5.0, 0.1)
    t0 = sim.time
    sim.set_surface_speed(6.0)
    tr = sim.run(60.0, 0.01)
    expected = 6.0 + (5.0 - 6.0) * np.exp(-(tr.tau - t0) / T_d)
    # RK4 on the linear lag at h = 2e-3 against its exponential: global error
    # ~ t h^4 / (120 T_d^5) · |Δω| ~ 60 · 1.6e-11 / 120 / 0.03 = 3e-10 (truncation; the
    # kernel's arithmetic is the same on every CPU)
    np.testing.assert_allclose(tr.surface_speed, expected, atol=1e-9)
    late = tr.tau > t0 + 40
    assert tr.bit_angular_speed[late].mean() == pytest.approx(6.0, rel=0.01)
    # the bit responds through the string: it lags the surface at first
    early = (tr.tau > t0) & (tr.tau < t0 + 0.3)
    assert np.all(tr.bit_angular_speed[early] < tr.surface_speed[early])


def test_hook_load_change_moves_wob_and_rop_to_the_new_steady_state():
    g = BitRockGroups(**QUIET)
    sim = Simulation(damped_rgd(g.psi), g, 2e-3)
    sim.set_axial_top_force(1.5)          # hook load lowered by 1.5 W*
    tr = sim.run(120.0, 0.01)
    late = tr.tau > 80
    W = QUIET['W_o'] + 1.5
    assert tr.weight_on_bit[late].mean() == pytest.approx(W, rel=0.01)
    rop = QUIET['omega_o'] * (W - QUIET['n_b'] * QUIET['lam']) / (2 * math.pi)  # eq. 2.4.5
    assert tr.bit_axial_speed[late].mean() == pytest.approx(rop, rel=0.01)


@pytest.mark.parametrize('bad', [float('nan'), float('inf'), -1.0])
def test_bad_commands_are_rejected_and_state_is_kept(bad):
    g = BitRockGroups(**QUIET)
    sim = Simulation(rgd(g.psi), g, 2e-3)
    sim.run(1.0, 0.1)
    before = sim.inputs.copy()
    with pytest.raises(ParameterError):
        sim.set_surface_speed(bad)
    if not math.isfinite(bad):
        with pytest.raises(ParameterError):
            sim.set_axial_top_force(bad)
    np.testing.assert_array_equal(sim.inputs, before)
    sim.run(1.0, 0.1)  # keeps running


def test_semi_infinite_axial_limit_is_stable():
    g = BitRockGroups(**dict(QUIET, W_o=5.0 + 1e-9))   # α_o ~ 0: axial decoupled from torsion
    dde = linearize_semi_infinite(g, 50.0, 1.0, 1.0)
    res = rightmost_roots(dde)
    assert res.zero_root and res.abscissa < 0


def test_motor_torque_channel():
    """The motor torque channel (docs/architecture.md, "add a channel"): the stiff drive
    has no motor model, its channel is the string's top torque; the PI motor drive's
    torque balances the surface torque on average — over a window the difference is the
    motor's angular momentum change J Δω divided by its length, here ~1e-4 of the torque
    (Δω = 3e-4/t* over 100 t*), so 1 % says the channel is the motor's torque and not
    something else. The twin measures it in SI and the table publishes it."""
    from drill_twin.config.scenario import load_scenario
    from drill_twin.physics.simulation import Simulation
    from drill_twin.runtime.digital_twin import DigitalTwin
    from drill_twin.topics import BY_NAME
    for overrides in ([], ['model.top_drive=motor']):
        sc = load_scenario('benchmark_fem', overrides)
        tr = Simulation.from_scenario(sc).run(200.0, 10 * sc.time_step)
        late = slice(len(tr) // 2, None)
        if not overrides:
            assert np.array_equal(tr.motor_torque, tr.surface_torque)
        else:
            assert np.abs(tr.motor_torque - tr.surface_torque).max() > 0.1  # a real motor
            assert tr.motor_torque[late].mean() == pytest.approx(
                tr.surface_torque[late].mean(), rel=1e-2)
    twin = DigitalTwin(load_scenario('benchmark_fem'))
    twin.advance_to(0.5)
    m = twin.measurements()
    assert m['motor_torque_Nm'] == m['surface_torque_Nm']
    assert BY_NAME['surface/motor_torque'].fields(m, {}) == {'data': m['surface_torque_Nm']}


def test_a_torque_limit_clips_the_motor_and_the_top_drive_slows():
    """rig_fem drills at ~2.4 kN·m; a 1.5 kN·m torque limit (the rig's VFD limit, OPC UA
    Rotation.MaxTorque) clips the PI drive's demand: the motor torque never exceeds it
    (exactly: the clip is in the kernel), so the motor cannot hold the set-point and slows;
    lifting the limit back to the rated 50 kN·m recovers the speed. Out of range or on a
    prescribed-speed string: refused, the last limit kept."""
    from drill_twin.config.scenario import load_scenario
    from drill_twin.runtime.digital_twin import DigitalTwin, SetpointError
    twin = DigitalTwin(load_scenario('rig_fem'))
    assert twin.rated_torque_Nm == 50.0e3 == twin.torque_limit_setpoint
    twin.advance_to(2.0)
    before = twin.measurements()
    assert before['motor_torque_Nm'] > 2.0e3
    twin.apply('torque_limit_setpoint', 1.5e3)
    torques, speeds = [], []
    for k in range(1, 301):
        twin.advance_to(2.0 + 0.01 * k)
        m = twin.measurements()
        torques.append(m['motor_torque_Nm'])
        speeds.append(m['top_drive_speed_rad_s'])
    assert max(torques) <= 1.5e3 * (1 + 1e-12)
    assert speeds[-1] < speeds[100] < before['top_drive_speed_rad_s'] - 0.05   # slowing
    for bad in (-1.0, 60.0e3, math.nan):
        with pytest.raises(SetpointError):
            twin.apply('torque_limit_setpoint', bad)
    assert twin.torque_limit_setpoint == 1.5e3
    twin.apply('torque_limit_setpoint', 50.0e3)
    twin.advance_to(12.0)
    assert twin.measurements()['top_drive_speed_rad_s'] == pytest.approx(
        twin.surface_speed_setpoint, rel=0.05)
    stiff = DigitalTwin(load_scenario('benchmark_fem'))
    with pytest.raises(SetpointError, match='motor top drive'):
        stiff.apply('torque_limit_setpoint', 1.0e3)
