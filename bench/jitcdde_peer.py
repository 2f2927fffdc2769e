"""Peer comparison: the RGD model over its smooth interval, drill_twin vs jitcdde.

Problem (identical for both): the SI benchmark's RGD model at steady drilling,
nominal past; at t = 0 the surface speed command steps by +1 % through a
first-order drive lag (T_d = 0.5 t*).  The delay τ_1 is state-dependent; for
jitcdde it is an extra state with τ_1' = 1 - Ω(t)/Ω(t - τ_1) (the derivative of
eq. 2.4.13), for drill_twin it is found by the history search.  The window ends
before the first stick/lift-off event (checked), where the dynamics is smooth.
Error: max |Ω_bit - Ω_ref| against drill_twin at a 16x smaller step.

:func:`work_precision` sweeps steps (drill_twin, the NumPy peer) and tolerances (jitcdde),
measures the error against a fine reference (drill_twin at 0.04/512 t*, checked against
jitcdde at rtol 1e-12) and the wall time, and reads the speed ratio at equal error off
the curves (log-log interpolation).
"""
from __future__ import annotations

import time

import numpy as np

from drill_twin.config.scenario import load_scenario
from drill_twin.physics.simulation import Simulation

T_DRIVE = 0.5
KICK = 1.01


def drill_twin_run(sc, h, t_end, dt_out):
    sim = Simulation(sc.model, sc.groups, h, drive_time_constant=T_DRIVE)
    sim.advance(1)                                   # JIT/cache load outside the timing
    sim = Simulation(sc.model, sc.groups, h, drive_time_constant=T_DRIVE)
    sim.set_surface_speed(KICK * sc.groups.omega_o)
    t0 = time.perf_counter()
    tr = sim.run(t_end, dt_out)
    return tr.tau, tr.bit_angular_speed, time.perf_counter() - t0, sim.event_count


def jitcdde_run(sc, times, rtol):
    from jitcdde import jitcdde, t, y
    g = sc.groups
    psi, nb, lam, beta = sc.model.psi, g.n_b, g.lam, g.beta
    om, up = g.omega_o, g.upsilon_o
    u, v, ph, w, tau1, thp, omp = (y(i) for i in range(7))
    delta = up * tau1 + u - y(0, t - tau1)
    W = nb * delta + nb * lam
    T = nb * delta + nb * lam * beta
    f = [v, -psi * (W - g.W_o), w, -(ph - thp) - (T - g.T_o),
         1 - (om + w) / (om + y(3, t - tau1)), omp, ((KICK - 1) * om - omp) / T_DRIVE]
    dde = jitcdde(f, max_delay=3 * g.tau_10, verbose=False)
    dde.set_integration_parameters(rtol=rtol, atol=rtol * 1e-3)
    dde.constant_past([0, 0, 0, 0, g.tau_10, 0, 0])
    dde.compile_C(verbose=False)
    t0 = time.perf_counter()
    dde.adjust_diff()  # only alters the (never delayed) drive state's past at t = 0
    out = np.array([om + dde.integrate(tt)[3] for tt in times[times > 0]])
    out = np.concatenate([np.full(np.sum(times <= 0), om), out])
    return out, time.perf_counter() - t0


def smooth_window(sc, h):
    """90 % of the time to the first interface event (stick, lift-off, bounce)."""
    sim = Simulation(sc.model, sc.groups, h, drive_time_constant=T_DRIVE)
    sim.set_surface_speed(KICK * sc.groups.omega_o)
    while sim.event_count == 0 and sim.time < 500.0:
        sim.advance(50)
    return 0.9 * sim.time


def compare(smoke=False):
    """For each drill_twin step, the loosest jitcdde tolerance with an equal or smaller
    error; returns rows (h, error, wall, rtol, jitcdde error, jitcdde wall)."""
    sc = load_scenario('benchmark_fem', ['model.type=rgd'])
    dt_out = 0.05
    t_end = smooth_window(sc, 0.02)
    if smoke:
        t_end = min(t_end, 4.0)
    tau_ref, om_ref, _, ev_ref = drill_twin_run(sc, 0.02 / 32, t_end, dt_out)
    assert ev_ref == 0, 'the comparison window must be smooth (no stick/lift-off events)'
    rows = []
    for h in ((0.01,) if smoke else (0.01, 0.005)):
        tau, om, wall_dt, _ = drill_twin_run(sc, h, t_end, dt_out)
        err_dt = float(np.abs(om - np.interp(tau, tau_ref, om_ref)).max())
        found = None
        for rtol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
            om_j, wall_j = jitcdde_run(sc, tau, rtol)
            err_j = float(np.abs(om_j - np.interp(tau, tau_ref, om_ref)).max())
            found = (rtol, err_j, wall_j)
            if err_j <= err_dt:
                break
        rows.append((h, err_dt, wall_dt) + found + (t_end,))
    return rows


#: output grid of the work-precision sweep [t*]: a multiple of every step, so all runs are
#: compared at the same instants without interpolation
DT_OUT = 0.04
DT_STEPS = (0.04, 0.02, 0.01, 0.005, 0.0025, 0.00125, 0.000625)
JIT_RTOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
NUMPY_STEPS = (0.04, 0.02, 0.01, 0.005, 0.0025)
#: the error range over which the speed ratio is read [rad/t*]
ERROR_RANGE = (1e-8, 1e-4)


def numpy_rgd_run(sc, h, t_end, dt_out):
    """What a researcher writes first for the same problem: RK4 in NumPy on the 6 states of
    the RGD with the drive lag, the delay by ``np.interp`` on the stored history of the bit
    angle and position (appended every step)."""
    g = sc.groups
    psi, nb, lam, beta = sc.model.psi, g.n_b, g.lam, g.beta
    om, up, blade = g.omega_o, g.upsilon_o, 2 * np.pi / g.n_b
    hist_t = list(np.arange(-3 * g.tau_10, 0.0, h))
    hist_phi = [om * t for t in hist_t]
    hist_u = [up * t for t in hist_t]

    def f(t, y):
        u, v, ph, w, thp, omp = y
        td = np.interp(om * t + ph - blade, hist_phi, hist_t)
        delta = up * t + u - np.interp(td, hist_t, hist_u)
        W = nb * delta + nb * lam
        T = nb * delta + nb * lam * beta
        return np.array([v, -psi * (W - g.W_o), w, -(ph - thp) - (T - g.T_o), omp,
                         ((KICK - 1) * om - omp) / T_DRIVE])

    every = int(round(dt_out / h))
    y = np.zeros(6)
    t = 0.0
    out = []
    t0 = time.perf_counter()
    for k in range(1, int(round(t_end / h)) + 1):
        k1 = f(t, y)
        k2 = f(t + h / 2, y + h / 2 * k1)
        k3 = f(t + h / 2, y + h / 2 * k2)
        k4 = f(t + h, y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        t = k * h
        hist_t.append(t)
        hist_phi.append(om * t + y[2])
        hist_u.append(up * t + y[0])
        if k % every == 0:
            out.append(om + y[3])
    return np.array(out), time.perf_counter() - t0


def _wall_at(curve, error):
    """Wall time at ``error`` on a work-precision curve [(error, wall)], by log-log
    interpolation between its points; None outside the errors it spans."""
    pts = sorted(curve)
    errs = np.log([e for e, _ in pts])
    walls = np.log([w for _, w in pts])
    x = np.log(error)
    if not errs[0] <= x <= errs[-1]:
        return None
    return float(np.exp(np.interp(x, errs, walls)))


def speed_ratios(curves, errors):
    """Peer wall / drill_twin wall at each error of ``errors`` (None where a curve does not
    reach it)."""
    out = {}
    for name, curve in curves.items():
        if name == 'drill_twin':
            continue
        ratios = []
        for e in errors:
            mine, theirs = _wall_at(curves['drill_twin'], e), _wall_at(curve, e)
            ratios.append(None if mine is None or theirs is None else theirs / mine)
        out[name] = ratios
    return out


def work_precision(smoke=False):
    """Work-precision curves on the RGD smooth interval: {name: [(error, wall)]}, the
    reference check (jitcdde at rtol 1e-12 against the reference) and the window [t*]."""
    sc = load_scenario('benchmark_fem', ['model.type=rgd'])
    t_end = smooth_window(sc, 0.02)
    t_end = DT_OUT * int((min(t_end, 4.0) if smoke else t_end) / DT_OUT)
    tau, ref, _, events = drill_twin_run(sc, DT_OUT / 512, t_end, DT_OUT)
    assert events == 0, 'the comparison window must be smooth (no stick/lift-off events)'

    def error(values):
        return float(np.abs(np.asarray(values)[:ref.size] - ref).max())
    curves = {'drill_twin': [], 'jitcdde': [], 'NumPy RK4': []}
    for h in DT_STEPS[:3] if smoke else DT_STEPS:
        runs = [drill_twin_run(sc, h, t_end, DT_OUT) for _ in range(3)]   # best of three
        curves['drill_twin'].append((error(runs[0][1]), min(r[2] for r in runs)))
    for rtol in JIT_RTOLS[:2] if smoke else JIT_RTOLS:
        om, wall = jitcdde_run(sc, tau, rtol)
        curves['jitcdde'].append((error(om), wall))
    for h in NUMPY_STEPS[:1] if smoke else NUMPY_STEPS:
        om, wall = numpy_rgd_run(sc, h, t_end, DT_OUT)
        curves['NumPy RK4'].append((error(om), wall))
    check = error(jitcdde_run(sc, tau, 1e-12)[0])
    return curves, check, t_end


def plot_work_precision(curves, path):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for (name, curve), marker in zip(curves.items(), 'osd'):
        pts = sorted(curve)
        ax.loglog([e for e, _ in pts], [w for _, w in pts], marker=marker, label=name)
    ax.axvspan(*ERROR_RANGE, color='0.92', zorder=0, label='target range')
    ax.set_xlabel('max |Ω_bit − Ω_ref| (rad/t*)')
    ax.set_ylabel('wall time (s)')
    ax.set_title('RGD smooth interval: work against precision')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == '__main__':
    for r in compare():
        print(r)
