"""The topic-level Soft-Torque loop (controller at 100 Hz and 1 kHz, zero-order hold,
stiff speed drive) reproduces the embedded Soft-Torque drive of §3.2.

Reference: the embedded model (drive inertia on the top node, k_f and c_f to the
motor) simulated by the same library; the loop is the one the two nodes run
(:func:`drill_twin.runtime.closed_loop.run_closed_loop`).  Stated tolerance: the
bit speed trajectories agree within 0.3 rad/s (2.4 % of Ω_o) over the first 60 s
(the remaining difference comes from the initial perturbation, which is spread
over 58 vs 59 torsional nodes, not from the controller rate).
"""
import numpy as np
import pytest

from drill_twin.config.scenario import load_scenario
from drill_twin.control.soft_torque import SoftTorqueController
from drill_twin.physics.parameters import soft_torque_si
from drill_twin.runtime.closed_loop import run_closed_loop
from drill_twin.runtime.digital_twin import DigitalTwin
from drill_twin.runtime.offline import run_scenario


@pytest.fixture(scope='module')
def embedded():
    sc = load_scenario('benchmark_fem', ['model.top_drive=soft_torque'])
    return run_scenario(sc, duration=60.0 / sc.scales.time_s)[0]


@pytest.mark.parametrize('rate, duration', [(100.0, 60.0), pytest.param(1000.0, 10.0,
                                                                         marks=pytest.mark.slow)])
def test_external_soft_torque_equals_embedded(embedded, rate, duration):
    sc = load_scenario('benchmark_fem')
    twin = DigitalTwin(sc)
    tun = soft_torque_si(sc.system)
    ctrl = SoftTorqueController(tun['inertia'], tun['stiffness'], tun['damping'],
                                max_accel_rad_s2=1e9, torque_filter_s=1e12)
    loop = run_closed_loop(twin, ctrl, rate, duration)
    ref = np.interp(loop['time'], embedded['time'], embedded['bit_angular_speed'])
    assert np.abs(loop['bit_angular_speed'] - ref).max() < 0.3
    # and the loop is not trivially equal: the controller does move the drive
    assert np.ptp(loop['command']) > 0.01


def test_soft_torque_controller_is_the_tuned_spring_dashpot():
    """Linear check: with T_s a step ΔT the virtual drive settles where k_f Δθ = ΔT and
    its free oscillation has the natural frequency sqrt(k_f/I_DS) = 1/t*."""
    sc = load_scenario('benchmark_fem')
    tun = soft_torque_si(sc.system)
    c = SoftTorqueController(tun['inertia'], tun['stiffness'], tun['damping'],
                             max_accel_rad_s2=1e9, torque_filter_s=1e12)
    c.reset(10.0, torque=0.0)
    dt = 1e-4
    speeds = [c.update(dt, 10.0, 500.0) for _ in range(int(60.0 / dt))]
    assert c.twist * tun['stiffness'] == pytest.approx(500.0, rel=1e-3)
    assert speeds[-1] == pytest.approx(10.0, abs=1e-6)   # settled: e^(-ξ t/t*) over 60 s
    # zero crossings of (ω - ω_set) give the damped period 2π t*/sqrt(1 - ξ²)
    dev = np.array(speeds) - 10.0
    crossings = np.flatnonzero(np.diff(np.sign(dev[: int(10 / dt)])) != 0)
    period = 2 * np.mean(np.diff(crossings[:6])) * dt
    expect = 2 * np.pi * sc.scales.time_s / np.sqrt(1 - tun['xi_opt'] ** 2)
    assert period == pytest.approx(expect, rel=0.01)
