"""The nodes' real-time policy without ROS: pacing (catch-up, slips, stamps), the health window,
speed arbitration, settings, the advisory worker process."""
import math

import numpy as np
import pytest

from drill_twin.config.scenario import load_scenario
from drill_twin.runtime.advisor import StabilityAdvisor
from drill_twin.runtime.arbitration import SpeedArbiter, Watchdog
from drill_twin.runtime.digital_twin import aligned_step
from drill_twin.runtime.health import ERROR, OK, WARN, EventWindow, human, worst
from drill_twin.runtime.pacing import Pacer
from drill_twin.runtime.settings import CONTROLLER_SETTINGS, TWIN_SETTINGS, check
from drill_twin.stability.spectrum import critical_speed, spectral_abscissa


class Loop:
    """A simulated real-time loop: ticks every ``period``, each advancing at most the plan's
    budget of steps of ``h`` (a stalled tick does no work)."""

    def __init__(self, pacer, h):
        self.p, self.h = pacer, h
        self.wall, self.sim = 0.0, 0.0
        self.outcomes = []

    def tick(self, stall=0.0, steps_cap=None):
        self.wall += self.p.period_s + stall
        plan = self.p.plan(self.wall, self.sim, int(self.wall * 1e9))
        steps = math.floor((plan.target_s - self.sim) / self.h + 1e-6)
        steps = min(steps, plan.max_steps if steps_cap is None else steps_cap)
        self.sim += max(steps, 0) * self.h
        self.outcomes.append(self.p.settle(self.wall, self.sim, plan, int(self.wall * 1e9)))


def test_pacing_follows_the_clock_without_drift():
    h = aligned_step(1.49e-3, 0.01)
    loop = Loop(Pacer(1.0, 0.01, h), h)
    for _ in range(10_000):
        loop.tick()
    assert loop.sim == pytest.approx(loop.wall, abs=h) and not any(loop.outcomes)


def test_a_stall_is_an_overrun_caught_up_within_a_bounded_number_of_ticks():
    h = aligned_step(1.49e-3, 0.01)
    pacer = Pacer(1.0, 0.01, h, catch_up=4, max_lag_s=0.5)
    loop = Loop(pacer, h)
    for _ in range(10):
        loop.tick()
    loop.tick(stall=0.2)                        # 20 periods late
    n = 1
    while loop.outcomes[-1] == 'overrun':
        loop.tick()
        n += 1
    # lag 0.2 s, caught up at 3 periods per tick: 7 ticks (bound 0.5/(3*0.01) = 17)
    assert loop.outcomes.count('overrun') == n - 1 and n - 1 <= math.ceil(0.2 / 0.03)
    assert loop.outcomes.count('slip') == 0
    assert loop.sim == pytest.approx(loop.wall, abs=h)


def test_a_long_stall_slips_instead_of_replaying_it_fast():
    h = aligned_step(1.49e-3, 0.01)
    pacer = Pacer(2.0, 0.01, h, max_lag_s=0.5)
    loop = Loop(pacer, h)
    loop.tick()
    loop.tick(stall=4.6)                       # the 4.6 s stall of the issue
    assert loop.outcomes[-1] == 'slip'
    sim_at_slip = loop.sim
    for _ in range(5):
        loop.tick()
    assert not any(loop.outcomes[-5:])         # on time again at once
    assert loop.sim - sim_at_slip == pytest.approx(5 * 0.02, abs=h)


def test_stamps_are_the_ros_time_of_the_simulated_instant_and_stay_continuous():
    h = aligned_step(1.49e-3, 0.01)
    pacer = Pacer(1.0, 0.01, h)
    loop = Loop(pacer, h)
    stamps = []
    for k in range(300):
        if k == 150:  # rate change: re-anchor at the current instant
            pacer.retime(loop.wall, loop.sim, real_time_factor=2.0)
        loop.tick()
        stamps.append(pacer.stamp_ns(loop.sim))
    gaps = np.diff(stamps) * 1e-9
    assert np.allclose(gaps, 0.01, atol=1e-9)   # evenly spaced, across the rate change


def test_a_rate_change_between_ticks_samples_a_new_instant_at_the_next_tick():
    """``ros2 param set real_time_factor`` lands between two ticks: the next tick samples the
    next instant of the new grid (before, it found its instant reached and published the
    same sample twice)."""
    h = aligned_step(1.43e-3, 0.01)
    pacer = Pacer(1.0, 0.01, h)
    loop = Loop(pacer, h)
    for _ in range(5):
        loop.tick()
    for factor in (2.0, 1.0):
        before = loop.sim
        pacer.retime(loop.wall + 0.004, loop.sim, real_time_factor=factor)
        loop.tick()
        assert loop.sim == pytest.approx(before + factor * 0.01, abs=1e-9)
        assert not loop.outcomes[-1]


def test_a_tick_out_of_budget_still_ends_on_the_sample_grid():
    """A tick far behind advances at most its budget, a whole number of samples: every
    sample it publishes lies on the grid of the publish period (before, a budget of
    4 samples + 4 steps gave samples 32 steps = 45.7 ms apart, off the 10 ms grid)."""
    h = aligned_step(1.43e-3, 0.01)
    pacer = Pacer(1.0, 0.01, h, catch_up=4, max_lag_s=0.5)
    loop = Loop(pacer, h)
    loop.tick()
    loop.tick(stall=0.3)
    while loop.outcomes[-1] == 'overrun':
        samples = loop.sim / 0.01
        assert samples == pytest.approx(round(samples), abs=1e-6)
        loop.tick()


def test_aligned_step_divides_the_period_and_never_lengthens_the_step():
    for step, period in ((1.49e-3, 0.01), (5e-3, 0.01), (3.25e-4, 0.05), (0.02, 0.01)):
        h = aligned_step(step, period)
        assert h <= step and abs(period / h - round(period / h)) < 1e-9
        assert h > step * (1 - 1 / math.ceil(period / step)) - 1e-15 or period < step


def test_event_window_counts_the_recent_past_and_keeps_totals():
    w = EventWindow(10.0)
    for t in range(11):
        w.add('overrun', float(t))
    assert w.recent('overrun', 10.0) == 11 and w.recent('overrun', 25.0) == 0
    assert w.total('overrun') == 11
    assert worst(None, None) == (OK, 'running')
    assert worst((WARN, 'a'), (ERROR, 'b'), (WARN, 'c')) == (ERROR, 'b')
    assert worst((WARN, 'a'), (WARN, 'c')) == (WARN, 'a; c')
    assert human(0.123456789) == '0.1235' and human(True) == 'true' and human(3) == '3'


def test_arbiter_operator_commands_and_silence():
    a = SpeedArbiter(12.0, timeout_s=0.5)
    assert a.source == 'operator'
    assert a.on_command(10.0, 1.0) == 10.0 and a.source == 'controller'
    assert a.check(1.4) is None
    assert a.check(1.6) == 12.0 and a.source == 'operator'
    assert a.check(5.0) is None                        # once per silence
    a.on_command(11.0, 6.0)
    assert a.on_operator(14.0, 6.1) == 14.0 and a.source == 'operator'
    w = Watchdog(1.0)
    assert w.silent and not w.expired(100.0)           # never fed: not an expiry


def test_settings_tables_ranges_and_checks():
    names = [s.name for s in TWIN_SETTINGS]
    assert len(names) == len(set(names))
    for s in TWIN_SETTINGS + CONTROLLER_SETTINGS:
        if s.low is not None:
            assert check(s, s.default) is None and s.low <= s.default <= s.high
            assert 'outside' in check(s, float('nan'))
            assert 'outside' in check(s, s.high * 2 + 1)
            assert 'number' in check(s, 'abc')
    ro = {s.name for s in TWIN_SETTINGS if s.read_only}
    assert ro == {'config', 'overrides', 'scenario', 'drive_time_constant_s',
                  'as_fast_as_possible', 'record_path', 'record_chunk_period_s', 'autostart',
                  'foxglove_port'}


@pytest.mark.slow
def test_advisor_worker_answers_like_the_stability_module_and_never_blocks():
    sc = load_scenario('benchmark_fem')
    advisor = StabilityAdvisor(sc.raw)
    try:
        assert advisor.poll() is None                          # nothing asked
        speed = sc.groups.omega_o / sc.scales.time_s
        wob = sc.groups.W_o * sc.scales.force_N
        assert advisor.request(speed, wob)
        assert not advisor.request(speed, wob)                 # one request in flight
        answer = None
        import time
        deadline = time.monotonic() + 60
        while answer is None and time.monotonic() < deadline:
            answer = advisor.poll()
            time.sleep(0.01)   # polling a child process, not synchronising ROS
        t_star = sc.scales.time_s
        assert answer['spectral_abscissa_1_s'] == pytest.approx(
            spectral_abscissa(sc.model, sc.groups) / t_star, rel=1e-9)
        wc = critical_speed(sc.model, sc.groups, 0.2, 60.0 * t_star, samples=12, rtol=1e-3)
        expected = math.nan if wc is None else wc / t_star   # None: unstable up to 60 rad/s
        assert answer['critical_surface_speed_rad_s'] == pytest.approx(expected, rel=1e-9,
                                                                       nan_ok=True)
        # below the friction threshold: an error answer, the worker lives on
        assert advisor.request(speed, 1.0)
        deadline = time.monotonic() + 60
        answer = None
        while answer is None and time.monotonic() < deadline:
            answer = advisor.poll()
            time.sleep(0.01)
        assert 'error' in answer and advisor.alive
    finally:
        advisor.close()
    assert not advisor.alive and advisor._proc.poll() is not None



def test_numba_cache_is_keyed_by_the_jitted_sources(tmp_path):
    """An edit of any physics file with a jitted function, or of the compiler settings,
    gives a new cache directory (stale machine code cannot run); an edit of a file without
    jitted code keeps the warm cache."""
    import shutil

    from drill_twin.physics import numba_cache
    src = tmp_path / 'physics'
    shutil.copytree(numba_cache.PHYSICS_DIR, src, ignore=shutil.ignore_patterns('__pycache__'))
    key = numba_cache.source_key(src)
    assert key == numba_cache.source_key()
    law = src / 'interface_law.py'
    law.write_text(law.read_text().replace('weights[b] * depths[b]',
                                           '1.0 * weights[b] * depths[b]'))
    assert numba_cache.source_key(src) != key
    law.write_text((numba_cache.PHYSICS_DIR / 'interface_law.py').read_text())
    assert numba_cache.source_key(src) == key
    stats = src / 'parameters.py'
    stats.write_text(stats.read_text() + '\n# a comment\n')
    assert numba_cache.source_key(src) == key
    # the Python API around the kernel names numba in its docstrings, compiles nothing
    api = src / 'simulation.py'
    assert b'numba' in api.read_bytes()
    api.write_text(api.read_text() + '\n# a comment\n')
    assert numba_cache.source_key(src) == key
    settings = src / 'jit.py'             # the compiler settings are part of the key
    settings.write_text(settings.read_text() + '\n# a comment\n')
    assert numba_cache.source_key(src) != key
    import numba
    assert numba.config.CACHE_DIR == str(numba_cache.cache_dir())
