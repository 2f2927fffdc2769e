"""The bit/rock interface law of Detournay & Defourny, set-valued, in one place (thesis eqs
2.2.4-2.2.9, 2.4.10-2.4.11, §3.3).

Dimensionless, in total (not perturbed) quantities: depth of cut ``d_b`` of each
blade (units d*, from :mod:`drill_twin.physics.bottom_surface`), weight on bit
``W`` (units W*), torque on bit ``T`` (units C).  A blade in contact with the rock
(``d_b > 0``) cuts with force ``d_b`` (both W and T, per blade), and its wear flat
carries at most ``λ``::

    W = W_c + W_f,  T = W_c + β W_f,   W_c = Σ_contact d_b,   W_f ∈ [0, λ n_contact]

(``n_contact`` the number of blades in contact; an evenly spaced bit has all its
n_b blades in or out together, giving the thesis's ``W = n_b δ + W_f``).  The
wear-flat force is set-valued on the bit axial velocity V: ``λ n_contact`` while
the bit moves down, 0 while it moves up or is off bottom, and in between while the
bit is axially stuck (V = 0), from the axial force balance.  The torque of the wear
flats is ``β W_f`` (``T_f/C = a μ γ W_f /(2C) = μγζ W_f/W*``).

Modes, switching functions and transitions
------------------------------------------
Within an integration step the interface holds a **mode** (angular slip or stick;
axial down, up or stuck; contact of each blade).  The mode is valid while every
switching function of :func:`switching` is >= 0:

* angular slip: bit speed Ω >= 0 (no backward rotation of a bit on the rock; off
  bottom the bit turns freely either way — the string unwinds after a connection);
* angular stick: the string torque ``T_req`` the clamp must hold does not exceed
  the resisting torque ``W_c + β W_f`` (static threshold);
* axial down / up: V >= 0 / -V >= 0 (while a blade touches the rock: off bottom the
  two modes are the same free motion);
* axial stuck: ``0 <= W_req - W_c <= λ n_contact`` (the reaction the rock must give
  lies within the wear-flat bounds); while also stuck angularly only lift-off
  (``W_req >= 0``) ends it — the rock blocks downward motion of a bit that does
  not turn;
* each blade: its depth of cut keeps its sign (contact or not), checked while the
  bit slips angularly or moves up (a bit stuck both ways cannot change depth).

Modes, switching functions and the aux values they read are indexed by the names of
:mod:`drill_twin.physics.layout` (``MODE``, ``ANGULAR``, ``AXIAL``, ``SWITCH``, ``AUX``).
When one becomes negative the step is cut at the crossing and
:func:`transition` applies the rule of that function; the kernel then settles
the mode consistent with the state (:func:`drill_twin.physics.kernel`).  No velocity
threshold is involved anywhere.
"""
from __future__ import annotations

from .jit import kernel_jit
from .layout import ANGULAR, AUX, AXIAL, MODE, SWITCH

__all__ = ['contact_forces', 'sliding_wear_flat', 'stuck_wear_flat', 'bit_weight',
           'bit_torque', 'switching', 'transition']

#: a switching function that does not apply in the mode: never the smallest
_BIG = 1e300


@kernel_jit(inline='always')
def contact_forces(depths, weights, mode, lam):
    """Cutting force ``W_c = Σ_contact w_b d_b`` and the wear-flat capacity
    ``λ Σ_contact w_b`` (``w_b`` blades per group)."""
    cut = 0.0
    blades = 0.0
    for b in range(depths.size):
        if mode[MODE.contact + b] == 1:
            cut += weights[b] * depths[b]
            blades += weights[b]
    return cut, lam * blades


@kernel_jit(inline='always')
def sliding_wear_flat(ax_mode, capacity):
    """W_f while the bit slides axially: the whole capacity moving down, none moving up."""
    return capacity if ax_mode == AXIAL.down else 0.0


@kernel_jit(inline='always')
def stuck_wear_flat(w_required, cut, capacity):
    """W_f of an axially stuck bit: the reaction the balance asks, within [0, capacity]."""
    return min(max(w_required - cut, 0.0), capacity)


@kernel_jit(inline='always')
def bit_weight(cut, wear_flat):
    """Weight on bit W = W_c + W_f (eq. 2.2.4)."""
    return cut + wear_flat


@kernel_jit(inline='always')
def bit_torque(cut, wear_flat, beta):
    """Torque on bit T = W_c + β W_f (eq. 2.2.5, units C)."""
    return cut + beta * wear_flat


@kernel_jit
def switching(mode, bit, depths, aux, beta, torsion, g):
    """Fill ``g`` (size 3 + blade groups, :data:`SWITCH`) with the switching functions of
    the mode (the mode holds while all are >= 0).  ``bit``: the bit's
    :class:`~drill_twin.physics.layout.BitMotion`; ``aux``: the cutting force, capacity and
    required reactions of the right-hand side (:data:`AUX`); ``torsion``: the model has a
    torsional chain."""
    for k in range(g.size):
        g[k] = _BIG
    ang = mode[MODE.angular]
    ax = mode[MODE.axial]
    cut, capacity = aux[AUX.cut], aux[AUX.capacity]
    w_required = aux[AUX.weight_required]
    on_rock = False
    for b in range(depths.size):
        if mode[MODE.contact + b] == 1:
            on_rock = True
    if ax == AXIAL.stuck:
        w_f = stuck_wear_flat(w_required, cut, capacity)
    else:
        w_f = sliding_wear_flat(ax, capacity)
    if torsion:
        if ang == ANGULAR.slip:
            if on_rock:
                g[SWITCH.angular] = bit.speed
        else:
            g[SWITCH.angular] = bit_torque(cut, w_f, beta) - aux[AUX.torque_required]
    if ax == AXIAL.down:
        if on_rock:
            g[SWITCH.axial_low] = bit.velocity
    elif ax == AXIAL.up:
        if on_rock:
            g[SWITCH.axial_low] = -bit.velocity
    elif ang == ANGULAR.stick:
        g[SWITCH.axial_low] = w_required
    else:
        g[SWITCH.axial_low] = w_required - cut
        g[SWITCH.axial_high] = capacity - (w_required - cut)
    if ang == ANGULAR.slip or ax == AXIAL.up:
        for b in range(depths.size):
            g[SWITCH.contact + b] = depths[b] if mode[MODE.contact + b] == 1 else -depths[b]


@kernel_jit
def transition(k, mode, w_required):
    """Apply the rule of switching function ``k`` that has just reached zero.

    Returns ``(stop_rotation, stop_descent)``: the bit speed (angular) or axial speed
    that crossed zero is to be set exactly to zero by the caller (the crossing is
    located to round-off; the velocity is then exactly 0, not a small number).
    """
    if k >= SWITCH.contact:
        b = k - SWITCH.contact
        mode[MODE.contact + b] = 1 - mode[MODE.contact + b]
        if mode[MODE.axial] == AXIAL.stuck:   # a stuck bit that gains or loses a blade
            mode[MODE.axial] = AXIAL.down if w_required > 0.0 else AXIAL.up  # re-slides
        return False, False
    if k == SWITCH.angular:
        if mode[MODE.angular] == ANGULAR.slip:
            return True, False          # the bit stops turning: settle decides stick
        mode[MODE.angular] = ANGULAR.slip   # the string torque breaks the bit free
        return False, False
    if mode[MODE.axial] == AXIAL.stuck:
        mode[MODE.axial] = AXIAL.up if k == SWITCH.axial_low else AXIAL.down
        return False, False
    return False, True                  # the bit stops moving axially: settle decides
