"""The bottom-hole surface as a function of angle (issue 14): against an independent root
finder for the delay formulation, off bottom, tagging bottom, stopped rotation in bounded
memory, uneven blades."""
import math
import tracemalloc

import numpy as np
import pytest
from scipy.optimize import brentq

from drill_twin.config.scenario import load_scenario
from drill_twin.physics.bottom_surface import (
    fill_flat,
    fill_steady,
    new_surface,
    read_surface,
    write_step,
)
from drill_twin.physics.layout import READ, SURFACE, BitMotion
from drill_twin.physics.simulation import Simulation

N_B = 6
PITCH = 2 * math.pi / N_B


def phi(t):  # monotone total angle: 5 + 2 cos(1.3 t) > 0
    return 5.0 * t + 2.0 * math.sin(1.3 * t) / 1.3


def dphi(t):
    return 5.0 + 2.0 * math.cos(1.3 * t)


def u(t):
    return 0.4 * t + 0.05 * math.sin(7.0 * t)


def du(t):
    return 0.4 + 0.35 * math.cos(7.0 * t)


def _swept(h, t_end, nodes=512, offsets=(0.0,), period=PITCH, min_gap=PITCH):
    surf, geom = new_surface(period, nodes, min_gap)
    fill_flat(surf, -1e9)                       # no rock left from before: all cut now
    ts = np.arange(-2.0, t_end + 1e-12, h)
    off = np.array(offsets)
    for t0, t1 in zip(ts[:-1], ts[1:]):
        write_step(surf, geom, off, t0, t1, BitMotion(u(t0), du(t0), phi(t0), dphi(t0)),
                   BitMotion(u(t1), du(t1), phi(t1), dphi(t1)))
    return surf, geom


@pytest.mark.parametrize('t_now', [1.0, 3.7, 8.25])
def test_rock_ahead_is_where_the_preceding_blade_was_one_pitch_earlier(t_now):
    """Eq. 2.4.13-2.4.14 by an independent root finder: the blade reads U(τ_d) with
    Φ(τ_d) = Φ(τ) - 2π/n_b, and the time τ_d."""
    h = 2e-3
    surf, geom = _swept(h, t_now, nodes=4 * int(PITCH / (5.0 * h)))
    out = np.zeros(len(READ))
    read_surface(surf, geom, phi(t_now), 0.0, out)
    t_ref = brentq(lambda t: phi(t) - (phi(t_now) - PITCH), t_now - 2.0, t_now, xtol=1e-15)
    # truncation, not round-off: the Hermite write O(h^4) and the cubic read O(Δξ^4) at
    # h = 2e-3, Δξ = 5h/4 (~1e-11 each, times the derivatives of u; 1e-9 leaves 100x); the
    # kernel runs in numba without fast-math, so its arithmetic is the same on every CPU
    assert out[READ.height] == pytest.approx(u(t_ref), abs=1e-9)   # O(h^4) + O(Δξ^4)
    assert out[READ.time] == pytest.approx(t_ref, abs=1e-8)   # the same, over dΦ/dτ
    assert out[READ.residual] < 1e-12    # Newton stops at 1e-14 (1 + |Φ|) rad, Φ ~ 20


def test_off_bottom_no_cut_and_tagging_bottom_again():
    """A bit above the rock leaves it as it was (S = max(S, U)); coming back down it cuts
    again from the rock that was there."""
    surf, geom = new_surface(PITCH, 128, PITCH)
    fill_flat(surf, 5.0)
    off = np.zeros(1)
    # one pitch of rotation 1 d* above the rock: nothing changes
    write_step(surf, geom, off, 0.0, 1.0, BitMotion(4.0, 0.0, 0.0, PITCH),
               BitMotion(4.0, 0.0, PITCH, PITCH))
    assert np.all(surf[SURFACE.height] == 5.0)
    out = np.zeros(len(READ))
    read_surface(surf, geom, 0.3 + PITCH, 0.0, out)
    assert out[READ.height] == pytest.approx(5.0)               # depth of cut 4 - 5 < 0
    # tag bottom: the bit 0.2 d* into the rock while turning one pitch
    write_step(surf, geom, off, 1.0, 2.0, BitMotion(5.2, 0.0, PITCH, PITCH),
               BitMotion(5.2, 0.0, 2 * PITCH, PITCH))
    assert np.allclose(surf[SURFACE.height], 5.2)
    read_surface(surf, geom, 2 * PITCH + 0.3, 0.0, out)
    assert out[READ.height] == pytest.approx(5.2)


def test_uneven_blades_each_cut_the_rock_of_the_blade_ahead():
    """Blades at 0, 50°, 170°, 240°: blade b reads the rock left by the blade ahead of it,
    one gap of rotation earlier (independent root finder for that instant)."""
    angles = np.radians([0.0, 50.0, 170.0, 240.0])
    gaps = np.diff(np.append(angles, angles[0] + 2 * np.pi))
    h = 2e-3
    surf, geom = _swept(h, 6.0, nodes=4096, offsets=angles, period=2 * np.pi,
                        min_gap=gaps.min())
    out = np.zeros(len(READ))
    t_now = 6.0
    for b, th in enumerate(angles):
        read_surface(surf, geom, phi(t_now), th, out)
        t_ref = brentq(lambda t, g=gaps[b]: phi(t) - (phi(t_now) - g), t_now - 3.0, t_now,
                       xtol=1e-15)
        assert out[READ.height] == pytest.approx(u(t_ref), abs=1e-8), b
        assert out[READ.time] == pytest.approx(t_ref, abs=1e-8), b


def test_steady_surface_gives_the_steady_depth_and_delay():
    surf, geom = new_surface(PITCH, 256, PITCH)
    ups, om = 0.47, 3.74
    fill_steady(surf, geom, [0.0], ups, om, t0=2.5)
    out = np.zeros(len(READ))
    read_surface(surf, geom, om * 2.5, 0.0, out)
    # a steady surface is read exactly (linear in ξ: the cubic has no truncation); a dozen
    # operations of round-off, ~1e-15, and the difference 2.5 - t loses 2.5/0.84 = 3x
    assert ups * 2.5 - out[READ.height] == pytest.approx(ups * PITCH / om, rel=1e-12)  # δ_o

    assert 2.5 - out[READ.time] == pytest.approx(PITCH / om, rel=1e-12)   # τ_1,0


@pytest.mark.parametrize('on_bottom', [True, False])
def test_stopped_rotary_for_ten_minutes_in_bounded_memory(on_bottom):
    """Surface speed 0 for 10 simulated minutes (a connection), on and off bottom: nothing
    overflows and the memory the run holds does not grow (the delay searched in a time
    history overflowed 11,660 times in 5 s before)."""
    sc = load_scenario('benchmark_fem')
    sim = Simulation.from_scenario(sc)
    sim.advance(200)
    if not on_bottom:  # pick up: a hook load above the string weight lifts the bit off
        sim.set_axial_top_force(-2.0 * sc.groups.W_o)
        sim.run(5.0 / sc.scales.time_s, record_interval=1.0)
        sim.set_axial_top_force(-sc.groups.W_o)   # then hold: the weight is on the hook
    sim.set_surface_speed(0.0)
    sizes = (sim.surface.nbytes, sim.th.nbytes)
    minute = 60.0 / sc.scales.time_s
    first = sim.run(minute, record_interval=0.05)
    tracemalloc.start()
    sim.advance(int(4 * minute / sim.h))
    before = tracemalloc.get_traced_memory()[0]
    sim.advance(int(4 * minute / sim.h))
    after = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    last = sim.run(minute, record_interval=0.05)
    snap = sim.snapshot()
    assert sim.history_overflows == 0
    assert (sim.surface.nbytes, sim.th.nbytes) == sizes
    assert after - before < 100_000
    assert abs(snap['surface_speed']) < 1e-12    # stopped: ω_o + (−ω_o), one rounding
    if on_bottom:  # the rock holds the bit: stuck, in contact
        assert abs(snap['bit_angular_speed']) < 1e-3
        assert snap['contact'] == 1.0
    else:
        # nothing holds a bit off bottom: the released string swings freely about a fixed
        # angle (benchmark torsional damping ratio ~1e-4) — no drift, no energy gained
        assert first.contact.max() == 0.0 and last.contact.max() == 0.0
        assert abs(last.bit_angle.mean() - first.bit_angle.mean()) < 0.5
        assert np.ptp(last.bit_angle) <= np.ptp(first.bit_angle)
        assert snap['depth_of_cut'] < 0.0               # above the rock
