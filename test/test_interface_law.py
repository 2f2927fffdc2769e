"""The set-valued bit/rock law (drill_twin.physics.interface_law), case by case.

The reference is the law as the thesis states it (eqs 2.2.4-2.2.9, §3.3) and as the
module's docstring restates it, written again here as plain Python tables: the cutting
and wear-flat forces, the switching function of every mode (angular slip / stick x axial
down / up / stuck x each blade group in or out of contact, with and without a torsional
chain) and the transition rule of every switching function in every mode."""
import itertools

import numpy as np
import pytest

from drill_twin.physics import interface_law as L
from drill_twin.physics.layout import ANGULAR, AUX, AXIAL, MODE, SWITCH, BitMotion

BIG = 1e300
LAM, BETA = 0.8, 0.6
DEPTHS = np.array([0.7, -0.2])        # group 0 cuts 0.7 d*, group 1 is 0.2 d* above rock
WEIGHTS = np.array([2.0, 3.0])        # blades per group


def _mode(ang, ax, contact):
    return np.array([ang, ax, *contact], np.int64)


def _aux(cut, cap, w_req, t_req):
    aux = np.zeros(len(AUX))
    aux[AUX.cut], aux[AUX.capacity] = cut, cap
    aux[AUX.weight_required], aux[AUX.torque_required] = w_req, t_req
    return aux


def reference_forces(contact):
    """W_c = Σ_contact w_b d_b, wear-flat capacity λ Σ_contact w_b (eq. 2.2.4)."""
    cut = sum(w * d for w, d, c in zip(WEIGHTS, DEPTHS, contact) if c)
    return cut, LAM * sum(w for w, c in zip(WEIGHTS, contact) if c)


def reference_wear_flat(ax, cut, cap, w_req):
    """W_f: λ n_contact moving down, 0 moving up, the balance within [0, cap] when stuck."""
    if ax == AXIAL.down:
        return cap
    if ax == AXIAL.up:
        return 0.0
    return min(max(w_req - cut, 0.0), cap)


def reference_switching(ang, ax, contact, omega, v, w_req, t_req, torsion):
    """The switching functions the module docstring lists, mode by mode."""
    cut, cap = reference_forces(contact)
    on_rock = any(contact)
    w_f = reference_wear_flat(ax, cut, cap, w_req)
    g = [BIG] * (3 + len(contact))
    if torsion:
        if ang == ANGULAR.slip:
            g[SWITCH.angular] = omega if on_rock else BIG          # off bottom: free either way
        else:
            g[SWITCH.angular] = cut + BETA * w_f - t_req           # static threshold
    if ax == AXIAL.down:
        g[SWITCH.axial_low] = v if on_rock else BIG
    elif ax == AXIAL.up:
        g[SWITCH.axial_low] = -v if on_rock else BIG
    elif ang == ANGULAR.stick:
        g[SWITCH.axial_low] = w_req                               # only lift-off ends it
    else:
        g[SWITCH.axial_low] = w_req - cut
        g[SWITCH.axial_high] = cap - (w_req - cut)
    if ang == ANGULAR.slip or ax == AXIAL.up:                  # depths can change
        for b, c in enumerate(contact):
            g[SWITCH.contact + b] = DEPTHS[b] if c else -DEPTHS[b]
    return g


MODES = list(itertools.product((ANGULAR.slip, ANGULAR.stick), (AXIAL.down, AXIAL.up, AXIAL.stuck),
                               itertools.product((0, 1), repeat=2)))


@pytest.mark.parametrize('contact', list(itertools.product((0, 1), repeat=2)))
def test_cutting_force_and_wear_flat_capacity(contact):
    cut, cap = L.contact_forces(DEPTHS, WEIGHTS, _mode(0, 0, contact), LAM)
    assert (cut, cap) == pytest.approx(reference_forces(contact), rel=0, abs=1e-15)


@pytest.mark.parametrize('w_req', [-1.0, 0.3, 1.2, 5.0])
def test_wear_flat_force_in_each_axial_mode(w_req):
    cut, cap = 0.7 * 2.0, LAM * 2.0
    assert L.sliding_wear_flat(AXIAL.down, cap) == cap
    assert L.sliding_wear_flat(AXIAL.up, cap) == 0.0
    assert L.stuck_wear_flat(w_req, cut, cap) == reference_wear_flat(AXIAL.stuck, cut, cap,
                                                                     w_req)
    w_f = 0.5
    assert L.bit_weight(cut, w_f) == cut + w_f                      # eq. 2.2.4
    assert L.bit_torque(cut, w_f, BETA) == cut + BETA * w_f         # eq. 2.2.5


@pytest.mark.parametrize('torsion', [True, False])
@pytest.mark.parametrize('ang, ax, contact', MODES)
def test_switching_functions_of_every_mode(ang, ax, contact, torsion):
    omega, v, w_req, t_req = 0.37, -0.11, 2.9, 1.7
    cut, cap = reference_forces(contact)
    g = np.empty(3 + len(contact))
    L.switching(_mode(ang, ax, contact), BitMotion(0.0, v, 0.0, omega), DEPTHS,
                _aux(cut, cap, w_req, t_req), BETA, torsion, g)
    expected = reference_switching(ang, ax, contact, omega, v, w_req, t_req, torsion)
    np.testing.assert_array_equal(g, expected)


@pytest.mark.parametrize('ang, ax, contact', MODES)
def test_transition_of_every_switching_function_in_every_mode(ang, ax, contact):
    """The rule of each function reaching zero: a blade's contact toggles (a stuck bit that
    gains or loses a blade slides again, down if pushed, up if pulled); a slipping bit
    whose speed reaches zero is to be stopped exactly (the kernel then settles stick or
    not); a stuck bit whose torque reaches the threshold slips; an axially stuck bit whose
    reaction leaves the wear-flat interval moves up (lower bound) or down (upper bound); an
    axially sliding bit whose speed reaches zero is to be stopped exactly."""
    for k in range(3 + len(contact)):
        for w_req in (1.5, -0.5):
            mode = _mode(ang, ax, contact)
            stop_rotation, stop_descent = L.transition(k, mode, w_req)
            expect = list(_mode(ang, ax, contact))
            stops = (False, False)
            if k >= SWITCH.contact:
                b = k - SWITCH.contact
                expect[MODE.contact + b] = 1 - contact[b]
                if ax == AXIAL.stuck:
                    expect[MODE.axial] = AXIAL.down if w_req > 0 else AXIAL.up
            elif k == SWITCH.angular:
                if ang == ANGULAR.slip:
                    stops = (True, False)
                else:
                    expect[MODE.angular] = ANGULAR.slip
            elif ax == AXIAL.stuck:
                expect[MODE.axial] = AXIAL.up if k == SWITCH.axial_low else AXIAL.down
            else:
                stops = (False, True)
            assert (stop_rotation, stop_descent) == stops, (k, w_req)
            np.testing.assert_array_equal(mode, expect)


def test_no_velocity_threshold_anywhere_in_the_law():
    """The law is set-valued: the smallest speed of either sign already switches (no
    regularising band around zero)."""
    g = np.empty(5)
    for omega in (1e-300, -1e-300):
        L.switching(_mode(ANGULAR.slip, AXIAL.down, (1, 1)), BitMotion(0.0, 0.5, 0.0, omega),
                    DEPTHS, _aux(0.0, 1.0, 0.0, 0.0), BETA, True, g)
        assert np.sign(g[SWITCH.angular]) == np.sign(omega)
