"""Well path (minimum curvature) and soft-string torque and drag (issue 33, items 1-2).

Every reference value is a closed form (straight inclined hole, capstan on an arc,
circle geometry) or an independent computation written here: Johancsik's explicit
per-segment formulas over short straight segments, on inclinations and azimuths this
file computes itself (linear build rates, Rodrigues rotation), never from the code
under test.  See docs/torque_drag.md."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from drill_twin.errors import ParameterError
from drill_twin.physics.parameters import StringSection
from drill_twin.physics.torque_drag import (
    PICK_UP,
    ROTATING,
    SLACK_OFF,
    Motion,
    broomstick,
    buoyed_weight_N_m,
    torque_drag,
    wob_for_hook_load,
)
from drill_twin.physics.well_path import (
    WellPath,
    dogleg_rad,
    ratio_factor,
    well_b_path,
)

G = 9.81            # the project's gravity (parameters.GRAVITY_M_S2)
STEEL = 7850.0
MUD = 1200.0
DEG = math.pi / 180.0


def _section(length, od, inner, name='pipe'):
    return StringSection(name, length, od, inner, STEEL, 207e9, 80e9)


def _w(od, inner, mud=MUD):
    """Buoyed weight per unit length [N/m], by hand."""
    return (STEEL - mud) * G * math.pi / 4 * (od ** 2 - inner ** 2)


PIPE = (0.127, 0.1086)
COLLAR = (0.1651, 0.0714)


def _string(collar_m=200.0, pipe_m=5000.0):
    return [_section(pipe_m, *PIPE), _section(collar_m, *COLLAR, name='collars')]


def _rel(a, b):
    return abs(a - b) / abs(b)


# --- (a) straight inclined hole: closed forms ---------------------------------------
INC, AZI, L = 40 * DEG, 30 * DEG, 2000.0
STRAIGHT = WellPath([0.0, L], [INC, INC], [AZI, AZI])


def test_straight_inclined_drag_and_torque_closed_forms():
    mu, w, r = 0.3, _w(*PIPE), PIPE[0] / 2
    sec = [_section(L, *PIPE)]
    up = torque_drag(STRAIGHT, sec, L, mu, PICK_UP, MUD)
    down = torque_drag(STRAIGHT, sec, L, mu, SLACK_OFF, MUD)
    rot = torque_drag(STRAIGHT, sec, L, mu, ROTATING, MUD)
    drag = mu * w * math.sin(INC) * L
    assert _rel(up.hook_load_N - rot.hook_load_N, drag) < 1e-9
    assert _rel(rot.hook_load_N - down.hook_load_N, drag) < 1e-9
    assert _rel(rot.hook_load_N, w * math.cos(INC) * L) < 1e-9
    assert _rel(rot.surface_torque_Nm, drag * r) < 1e-9
    assert up.surface_torque_Nm == 0.0 and down.surface_torque_Nm == 0.0
    s = up.measured_depth_m
    assert np.allclose(up.tension_N, (w * math.cos(INC) + mu * w * math.sin(INC)) * (L - s),
                       rtol=1e-9, atol=1e-6)
    assert np.allclose(up.normal_force_N_m, w * math.sin(INC), rtol=1e-12)


def test_straight_inclined_on_bottom_two_sections_and_combined_motion():
    mu, wob, tob = 0.25, 8e4, 3e3
    strings = _string(collar_m=300.0, pipe_m=L - 300.0)
    wl = _w(*PIPE) * (L - 300.0) + _w(*COLLAR) * 300.0          # Σ w_i L_i
    torque_r = _w(*PIPE) * (L - 300.0) * PIPE[0] / 2 + _w(*COLLAR) * 300.0 * COLLAR[0] / 2
    rot = torque_drag(STRAIGHT, strings, L, mu, ROTATING, MUD, wob, tob)
    assert _rel(rot.hook_load_N, wl * math.cos(INC) - wob) < 1e-9
    assert _rel(rot.surface_torque_Nm, tob + mu * math.sin(INC) * torque_r) < 1e-9
    v, omega = 0.2, 10.0                       # pulling out while rotating
    both = torque_drag(STRAIGHT, strings, L, mu, Motion(v, omega), MUD, wob, tob)
    axial = sum(_w(*sec) * n * v / math.hypot(v, omega * sec[0] / 2)
                for sec, n in ((PIPE, L - 300.0), (COLLAR, 300.0)))
    tang = sum(_w(*sec) * n * sec[0] / 2 * omega * sec[0] / 2 / math.hypot(v, omega * sec[0] / 2)
               for sec, n in ((PIPE, L - 300.0), (COLLAR, 300.0)))
    assert _rel(both.hook_load_N, wl * math.cos(INC) - wob + mu * math.sin(INC) * axial) < 1e-9
    assert _rel(both.surface_torque_Nm, tob + mu * math.sin(INC) * tang) < 1e-9


def test_vertical_well_has_no_wall_force():
    path = WellPath.vertical(3000.0)
    for motion in (PICK_UP, SLACK_OFF, ROTATING):
        res = torque_drag(path, _string(), 2500.0, 0.4, motion, MUD, 5e4)
        assert np.all(res.normal_force_N_m == 0.0) and res.surface_torque_Nm == 0.0
        assert _rel(res.hook_load_N, _w(*PIPE) * 2300.0 + _w(*COLLAR) * 200.0 - 5e4) < 1e-12


# --- (b) capstan on a constant-curvature arc, weightless string ----------------------
def test_capstan_build_section():
    theta, length, t_bit, mu = math.pi / 2, 1000.0, 1e5, 0.3
    path = WellPath([0.0, length], [0.0, theta], [0.0, 0.0])
    sec, r = [_section(length, *PIPE)], PIPE[0] / 2
    up = torque_drag(path, sec, length, mu, PICK_UP, MUD, -t_bit, gravity_m_s2=0.0)
    down = torque_drag(path, sec, length, mu, SLACK_OFF, MUD, -t_bit, gravity_m_s2=0.0)
    push = torque_drag(path, sec, length, mu, SLACK_OFF, MUD, t_bit, gravity_m_s2=0.0)
    rot = torque_drag(path, sec, length, mu, ROTATING, MUD, -t_bit, gravity_m_s2=0.0)
    assert _rel(up.hook_load_N, t_bit * math.exp(mu * theta)) < 1e-6
    assert _rel(down.hook_load_N, t_bit * math.exp(-mu * theta)) < 1e-6
    assert _rel(push.hook_load_N, -t_bit * math.exp(mu * theta)) < 1e-6   # pushing in
    assert _rel(rot.hook_load_N, t_bit) < 1e-12
    assert _rel(rot.surface_torque_Nm, mu * t_bit * theta * r) < 1e-9
    s = up.measured_depth_m
    assert np.allclose(up.tension_N, t_bit * np.exp(mu * (length - s) * theta / length),
                       rtol=1e-6)


def test_capstan_on_a_three_dimensional_dogleg():
    """Build and turn in one leg: T_top = T_bit e^{μβ}, β from the survey formula."""
    i1, a1, i2, a2 = 20 * DEG, 10 * DEG, 80 * DEG, 130 * DEG
    beta = math.acos(math.cos(i2 - i1) - math.sin(i1) * math.sin(i2) * (1 - math.cos(a2 - a1)))
    path = WellPath([0.0, 300.0, 1300.0, 1500.0], [i1, i1, i2, i2], [a1, a1, a2, a2])
    res = torque_drag(path, [_section(1500.0, *PIPE)], 1500.0, 0.35, PICK_UP, MUD, -2e5,
                      gravity_m_s2=0.0)
    assert _rel(res.hook_load_N, 2e5 * math.exp(0.35 * beta)) < 1e-6


def test_runge_kutta_converges_at_fourth_order():
    theta, length, mu = math.pi / 2, 1000.0, 0.8
    path = WellPath([0.0, length], [0.0, theta], [0.0, 0.0])
    exact = math.exp(mu * theta)
    errors = [abs(torque_drag(path, [_section(length, *PIPE)], length, mu, PICK_UP, MUD, -1.0,
                              gravity_m_s2=0.0, max_step_m=h).hook_load_N - exact)
              for h in (250.0, 125.0, 62.5)]
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(12.0 < q < 20.0 for q in ratios), ratios


# --- (c) minimum curvature against circle geometry ------------------------------------
@pytest.mark.parametrize('azimuth', [0.0, 90 * DEG, 225 * DEG])
def test_quarter_circle_build(azimuth):
    R = 700.0
    path = WellPath([0.0, math.pi * R / 2], [0.0, math.pi / 2], [azimuth, azimuth])
    north, east, tvd = path.station_position_m[-1]
    assert np.allclose([north, east, tvd], [R * math.cos(azimuth), R * math.sin(azimuth), R],
                       rtol=0, atol=1e-9 * R)
    s = np.linspace(0.0, math.pi * R / 2, 17)
    a = s / R
    horiz = R * (1 - np.cos(a))
    want = np.stack([horiz * math.cos(azimuth), horiz * math.sin(azimuth), R * np.sin(a)], -1)
    assert np.allclose(path.position(s), want, atol=1e-9 * R)
    assert np.allclose(path.inclination(s), a, atol=1e-12)
    assert np.allclose(path.curvature(s), 1 / R, rtol=1e-12)
    t = path.tangent(s)
    assert np.allclose(t[:, 2], np.cos(a)) and np.allclose(np.hypot(t[:, 0], t[:, 1]), np.sin(a))
    assert np.allclose(path.normal(s)[:, 2], -np.sin(a), atol=1e-12)
    assert np.allclose(path.azimuth(s[1:]), azimuth, atol=1e-12)


def test_straight_hold_section():
    pos = STRAIGHT.position([0.0, 700.0, L])
    t = np.array([math.sin(INC) * math.cos(AZI), math.sin(INC) * math.sin(AZI), math.cos(INC)])
    assert np.allclose(pos, np.outer([0.0, 700.0, L], t), atol=1e-9)
    assert np.all(STRAIGHT.curvature([0.0, L]) == 0.0)
    assert np.allclose(STRAIGHT.inclination(1000.0), INC) and np.allclose(
        STRAIGHT.azimuth(1000.0), AZI)


def _unit(i, a):
    return np.array([math.sin(i) * math.cos(a), math.sin(i) * math.sin(a), math.cos(i)])


def test_three_dimensional_arc_is_a_circle():
    i1, a1, i2, a2, ds = 30 * DEG, 300 * DEG, 75 * DEG, 20 * DEG, 800.0
    path = WellPath([0.0, 500.0, 500.0 + ds], [i1, i1, i2], [a1, a1, a2])
    beta = math.acos(math.cos(i2 - i1) - math.sin(i1) * math.sin(i2) * (1 - math.cos(a2 - a1)))
    assert abs(float(dogleg_rad(i1, a1, i2, a2)) - beta) < 1e-12
    t1, t2, R = _unit(i1, a1), _unit(i2, a2), ds / beta
    r1 = 500.0 * t1
    chord = 2 * R * math.sin(beta / 2) * (t1 + t2) / np.linalg.norm(t1 + t2)
    assert np.allclose(path.station_position_m[-1], r1 + chord, atol=1e-9)
    centre = r1 + R * (t2 - math.cos(beta) * t1) / math.sin(beta)
    s = np.linspace(500.0, 500.0 + ds, 9)
    p = path.position(s)
    assert np.allclose(np.linalg.norm(p - centre, axis=1), R, rtol=1e-12)
    cosang = (p - centre) @ (r1 - centre) / R ** 2
    assert np.allclose(np.arccos(np.clip(cosang, -1, 1)), (s - 500.0) / R, atol=1e-9)
    t = path.tangent(s)
    assert np.allclose(np.sum(t * (p - centre), axis=1), 0.0, atol=1e-9 * R)
    assert np.allclose(t[-1], t2, atol=1e-12)
    assert np.allclose(path.curvature(s[:-1]), beta / ds, rtol=1e-12)
    fine = path.resample(np.linspace(0.0, 1300.0, 53))
    assert np.allclose(fine.position(s), p, atol=1e-9)


def test_ratio_factor_limit():
    assert ratio_factor(0.0) == 1.0
    for beta in (1e-9, 1e-5, 0.99e-4, 1.01e-4, 1e-3):               # series of tan x / x
        series = 1 + beta ** 2 / 12 + beta ** 4 / 120 + 17 * beta ** 6 / 20160
        assert _rel(float(ratio_factor(beta)), series) < 1e-15
    for beta in (0.1, 0.5, 2.0, 3.0):
        assert _rel(float(ratio_factor(beta)), 2 / beta * math.tan(beta / 2)) < 1e-14
    path = WellPath([0.0, 100.0], [0.3, 0.3 + 1e-10], [1.0, 1.0])
    assert np.allclose(path.station_position_m[-1], 100.0 * _unit(0.3 + 5e-11, 1.0), atol=1e-10)


def test_well_b_profile():
    path = well_b_path()
    R = 1100.0 / (math.pi / 3)
    north = R * (1 - math.cos(math.pi / 3)) + 900.0 * math.sin(math.pi / 3)
    tvd = 500.0 + R * math.sin(math.pi / 3) + 900.0 * math.cos(math.pi / 3)
    assert np.allclose(path.station_position_m[-1], [north, 0.0, tvd], atol=1e-8)
    assert path.total_depth_m == 2500.0
    assert np.allclose(path.inclination([250.0, 1050.0, 2000.0]),
                       [0.0, 60 * DEG * 550 / 1100, 60 * DEG], atol=1e-12)
    assert np.max(np.diff(path.measured_depth_m)) <= 10.0 + 1e-9


# --- (d) J and S wells against Johancsik's explicit per-segment formulas -------------------
def _planar(knots_md, knots_inc, td, azimuth):
    """Inclination linear in MD between knots: I(s), A(s) exactly, by hand."""
    return (lambda s: np.interp(s, knots_md, knots_inc)), (lambda s: np.full_like(s, azimuth))


J_WELL = ([0.0, 600.0, 1500.0], [0.0, 0.0, 55 * DEG], 3200.0, 40 * DEG)
S_WELL = ([0.0, 500.0, 1100.0, 2000.0, 2600.0], [0.0, 0.0, 35 * DEG, 35 * DEG, 5 * DEG],
          3200.0, 200 * DEG)
TURN_WELL = [(0.0, 0.0, 0.0), (400.0, 0.0, 0.0), (1000.0, 40.0, 30.0), (1800.0, 70.0, 95.0),
             (3200.0, 70.0, 95.0)]


def _rodrigues(stations):
    """I(s), A(s) of a survey by rotating each station tangent towards the next one about
    their common normal (an independent construction of the circular arcs)."""
    md = np.array([st[0] for st in stations])
    tang = [_unit(st[1] * DEG, st[2] * DEG) for st in stations]

    def tangent(s):
        k = min(np.searchsorted(md, s, side='right') - 1, len(md) - 2)
        t1, t2 = tang[k], tang[k + 1]
        axis = np.cross(t1, t2)
        if np.linalg.norm(axis) == 0.0:
            return t1
        axis /= np.linalg.norm(axis)
        beta = math.atan2(np.linalg.norm(np.cross(t1, t2)), t1 @ t2)
        phi = beta * (s - md[k]) / (md[k + 1] - md[k])
        return t1 * math.cos(phi) + np.cross(axis, t1) * math.sin(phi)

    def angles(s):
        t = np.array([tangent(x) for x in s])
        return np.arccos(np.clip(t[:, 2], -1, 1)), np.arctan2(t[:, 1], t[:, 0])
    return angles


def _johancsik(inc, azi, md, w, r, mu, sign, wob, tob):
    """Johancsik et al. (1984) per segment, from the bit up: ΔT = W cos Ī + sign μ F_n,
    F_n = sqrt((T ΔA sin Ī)² + (T ΔI + W sin Ī)²), ΔM = μ F_n r (rotating)."""
    T, M = -wob, tob
    for k in range(md.size - 2, -1, -1):
        W, i_bar = w[k] * (md[k + 1] - md[k]), 0.5 * (inc[k] + inc[k + 1])
        d_inc = inc[k] - inc[k + 1]
        d_azi = (azi[k] - azi[k + 1] + math.pi) % (2 * math.pi) - math.pi
        fn = math.hypot(T * d_azi * math.sin(i_bar), T * d_inc + W * math.sin(i_bar))
        T += W * math.cos(i_bar) + sign * mu * fn
        M += mu * fn * r[k] * (sign == 0)
    return T, M


def _reference(md, inc, azi, bit, collar_m, mu, sign, wob=0.0, tob=0.0):
    mid = 0.5 * (md[:-1] + md[1:])
    collar = mid > bit - collar_m
    w = np.where(collar, _w(*COLLAR), _w(*PIPE))
    r = np.where(collar, COLLAR[0] / 2, PIPE[0] / 2)
    return _johancsik(inc, azi, md, w, r, mu, sign, wob, tob)


def _survey_path(case):
    if isinstance(case, list):
        return (WellPath([st[0] for st in case], [st[1] * DEG for st in case],
                         [st[2] * DEG for st in case]), _rodrigues(case))
    knots_md, knots_inc, td, azimuth = case
    inc_f, azi_f = _planar(*case)
    md = np.append(knots_md, td)
    return (WellPath(md, np.interp(md, knots_md, knots_inc), np.full(md.size, azimuth)),
            lambda s: (inc_f(s), azi_f(s)))


@pytest.mark.parametrize('case', [J_WELL, S_WELL, TURN_WELL], ids=['J', 'S', 'turn'])
def test_j_s_and_turning_wells_against_johancsik(case):
    path, angles = _survey_path(case)
    bit, collar_m, mu = 3200.0, 220.0, 0.3
    string = _string(collar_m=collar_m)
    md = np.linspace(0.0, bit, 6401)                   # 0.5 m segments
    inc, azi = angles(md)
    for motion, sign, wob, tob in ((PICK_UP, 1, 0.0, 0.0), (SLACK_OFF, -1, 0.0, 0.0),
                                   (ROTATING, 0, 0.0, 0.0), (ROTATING, 0, 1.2e5, 4e3),
                                   (SLACK_OFF, -1, 6e4, 0.0)):
        res = torque_drag(path, string, bit, mu, motion, MUD, wob, tob)
        hook, torque = _reference(md, inc, azi, bit, collar_m, mu, sign, wob, tob)
        assert _rel(res.hook_load_N, hook) < 0.01, (motion, res.hook_load_N, hook)
        if sign == 0:
            assert _rel(res.surface_torque_Nm, torque) < 0.01, (res.surface_torque_Nm, torque)


# --- hook load inversion and the broomstick chart ----------------------------------------
def test_wob_for_hook_load_closed_forms_and_round_trip():
    mu, sec = 0.3, [_section(L, *PIPE)]
    w = _w(*PIPE)
    hook = 0.6 * w * L * math.cos(INC)
    rot = wob_for_hook_load(STRAIGHT, sec, L, hook, mu, ROTATING, MUD)
    assert _rel(rot, w * L * math.cos(INC) - hook) < 1e-9
    slide = wob_for_hook_load(STRAIGHT, sec, L, hook, mu, SLACK_OFF, MUD)
    assert _rel(slide, w * L * (math.cos(INC) - mu * math.sin(INC)) - hook) < 1e-9
    path, string = well_b_path(), _string()
    for motion in (ROTATING, SLACK_OFF, Motion(-0.005, 12.0)):
        wob = wob_for_hook_load(path, string, 2500.0, 2.5e5, 0.25, motion, MUD)
        assert wob > 0.0
        again = torque_drag(path, string, 2500.0, 0.25, motion, MUD, wob).hook_load_N
        assert abs(again - 2.5e5) < 1e-3


def test_broomstick_chart():
    path = well_b_path()
    sec = [_section(3000.0, *PIPE)]
    depths = np.array([300.0, 800.0, 1400.0, 2500.0])
    chart = broomstick(path, sec, depths, MUD, [0.0, 0.2, 0.4])
    assert chart.pick_up_N.shape == (3, 4) and chart.rotating_torque_Nm.shape == (3, 4)
    assert np.allclose(chart.pick_up_N[0], chart.slack_off_N[0], rtol=1e-12)
    assert np.all(chart.pick_up_N[1:, 1:] > chart.rotating_N[1:, 1:])
    assert np.all(chart.rotating_N[1:, 1:] > chart.slack_off_N[1:, 1:])
    assert np.all(np.diff(chart.pick_up_N, axis=0)[:, 1:] > 0)
    assert np.all(chart.rotating_torque_Nm[0] == 0.0)
    assert np.allclose(chart.rotating_torque_Nm[2], 2 * chart.rotating_torque_Nm[1], rtol=1e-12)
    R = 1100.0 / (math.pi / 3)
    tvd = [300.0, 500.0 + R * math.sin(300.0 / R), 500.0 + R * math.sin(900.0 / R),
           500.0 + R * math.sin(math.pi / 3) + 900.0 * 0.5]
    assert np.allclose(chart.rotating_N, _w(*PIPE) * np.array(tvd), rtol=1e-9)
    vertical = chart.pick_up_N[:, 0]                                   # bit at 300 m
    assert np.allclose(vertical, _w(*PIPE) * 300.0, rtol=1e-12)


def test_nodes_and_buoyancy():
    res = torque_drag(well_b_path(), _string(), 1234.5, 0.2, PICK_UP, MUD, nodes_m=[777.7])
    s = res.measured_depth_m
    assert s[0] == 0.0 and s[-1] == 1234.5 and np.all(np.diff(s) > 0) and 777.7 in s
    assert np.all(np.diff(s) <= 2.0 + 1e-9)
    sec = _section(10.0, *COLLAR)
    assert _rel(buoyed_weight_N_m(sec, MUD), STEEL * G * math.pi / 4 * (
        COLLAR[0] ** 2 - COLLAR[1] ** 2) * (1 - MUD / STEEL)) < 1e-14


# --- (e) bad input ------------------------------------------------------------------------
_GOOD = ([0.0, 100.0, 200.0], [0.0, 0.1, 0.2], [0.0, 0.0, 0.0])


def _td(**kw):
    args = dict(path=STRAIGHT, sections=[_section(L, *PIPE)], bit_depth_m=L, friction_factor=0.3,
                motion=PICK_UP, mud_density_kg_m3=MUD)
    args.update(kw)
    return torque_drag(**args)


BAD = {
    'nan md': lambda: WellPath([0.0, math.nan, 200.0], *_GOOD[1:]),
    'md not increasing': lambda: WellPath([0.0, 100.0, 100.0], *_GOOD[1:]),
    'first md not 0': lambda: WellPath([10.0, 100.0, 200.0], *_GOOD[1:]),
    'inclination > pi': lambda: WellPath(_GOOD[0], [0.0, 0.1, 3.2], _GOOD[2]),
    'negative inclination': lambda: WellPath(_GOOD[0], [0.0, -0.1, 0.2], _GOOD[2]),
    'inf azimuth': lambda: WellPath(_GOOD[0], _GOOD[1], [0.0, math.inf, 0.0]),
    'lengths differ': lambda: WellPath(_GOOD[0], _GOOD[1][:2], _GOOD[2]),
    'one station': lambda: WellPath([0.0], [0.0], [0.0]),
    'opposite tangents': lambda: WellPath([0.0, 100.0], [0.0, math.pi], [0.0, 0.0]),
    '2-D survey': lambda: WellPath([[0.0, 1.0]], [[0.0, 0.0]], [[0.0, 0.0]]),
    'vertical depth 0': lambda: WellPath.vertical(0.0),
    'depth outside path': lambda: STRAIGHT.position(L + 1.0),
    'negative depth': lambda: STRAIGHT.tangent(-1.0),
    'bit below path': lambda: _td(bit_depth_m=L + 1.0),
    'bit at surface': lambda: _td(bit_depth_m=0.0),
    'negative friction': lambda: _td(friction_factor=-0.1),
    'nan friction': lambda: _td(friction_factor=math.nan),
    'mud heavier than steel': lambda: _td(mud_density_kg_m3=9000.0),
    'negative mud': lambda: _td(mud_density_kg_m3=-1.0),
    'at rest': lambda: Motion(0.0, 0.0),
    'unknown motion': lambda: _td(motion='tripping'),
    'string too short': lambda: _td(sections=[_section(L - 1.0, *PIPE)]),
    'inf wob': lambda: _td(weight_on_bit_N=math.inf),
    'zero step': lambda: _td(max_step_m=0.0),
    'nan node': lambda: _td(nodes_m=[math.nan]),
    'negative gravity': lambda: _td(gravity_m_s2=-9.81),
    'not a path': lambda: _td(path='vertical'),
    'inner >= outer': lambda: _td(sections=[SimpleNamespace(
        length_m=L, outer_diameter_m=0.1, inner_diameter_m=0.1, density_kg_m3=STEEL)]),
    'hook load above off-bottom': lambda: wob_for_hook_load(
        STRAIGHT, [_section(L, *PIPE)], L, 1e9, 0.3, ROTATING, MUD),
    'no bit depths': lambda: broomstick(STRAIGHT, [_section(L, *PIPE)], [], MUD),
}


@pytest.mark.parametrize('name', sorted(BAD))
def test_bad_input_raises_parameter_error(name):
    with pytest.raises(ParameterError) as info:
        BAD[name]()
    assert '\n' not in str(info.value) and str(info.value)
