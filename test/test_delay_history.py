"""State-dependent delay search (eqs 2.4.13-2.4.14) against an independent root finder."""
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from drill_twin.physics.delay_history import delayed_state, new_history, push_sample

N_B = 6
BLADE = 2 * math.pi / N_B


def phi(t):  # monotone total angle: 5 + 2 cos(1.3 t) > 0
    return 5.0 * t + 2.0 * math.sin(1.3 * t) / 1.3


def dphi(t):
    return 5.0 + 2.0 * math.cos(1.3 * t)


def u(t):
    return 0.4 * t + 0.05 * math.sin(7.0 * t)


def du(t):
    return 0.4 + 0.35 * math.cos(7.0 * t)


def _filled(h, t_end, capacity=100000):
    hist, meta = new_history(capacity)
    for t in np.arange(-2.0, t_end + 1e-12, h):
        push_sample(hist, meta, t, u(t), phi(t), du(t), dphi(t))
    return hist, meta


@pytest.mark.parametrize('t_now', [1.0, 3.7, 8.25])
def test_delay_matches_brentq_and_residual_is_small(t_now):
    h = 2e-3
    hist, meta = _filled(h, t_now)
    out = np.zeros(3)
    delayed_state(hist, meta, phi(t_now) - BLADE, out)
    t_ref = brentq(lambda t: phi(t) - (phi(t_now) - BLADE), t_now - 2.0, t_now, xtol=1e-15)
    assert out[0] == pytest.approx(t_ref, abs=1e-10)        # Hermite error O(h^4)
    assert out[1] == pytest.approx(u(t_ref), abs=1e-10)
    assert abs(out[2]) < 1e-6 * BLADE                       # residual of eq. 2.4.14


def test_frozen_bit_costs_no_memory_and_is_found():
    hist, meta = new_history(64)
    for t in np.arange(0.0, 0.5, 0.01):
        push_sample(hist, meta, t, t, 10 * t, 1.0, 10.0)
    frozen = (meta[1])
    for t in np.arange(0.5, 50.0, 0.01):  # stuck: U, Φ constant for 4950 steps
        push_sample(hist, meta, t, 0.49, 4.9, 0.0, 0.0)
    assert meta[1] <= frozen + 2 and meta[2] == 0
    out = np.zeros(3)
    delayed_state(hist, meta, 2.0, out)   # inside the moving part
    assert out[0] == pytest.approx(0.2, abs=1e-12)
    assert meta[2] == 0


def test_overflow_is_counted_not_silent():
    hist, meta = new_history(16)
    for t in np.arange(0.0, 1.0, 0.01):
        push_sample(hist, meta, t, t, t, 1.0, 1.0)
    out = np.zeros(3)
    delayed_state(hist, meta, 0.1, out)
    assert meta[2] == 1
