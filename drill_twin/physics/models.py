"""Drill-string models as chains of dimensionless mass/spring/dash-pot matrices.

Every model of the thesis is one instance of the same perturbation equations
(time τ = t/t*, axial displacement u = (U-U_o)/d*, angle φ = Φ-Φ_o):

    M_a u'' + C_a u' + K_a u = e_0 (k_a^top u_p + c_a^top u_p' + f_top) - ψ (W - W_o) e_bit
    M_t φ'' + C_t φ' + K_t φ = e_0 (k_t^top θ_p + c_t^top θ_p' + m_t^top θ_p'') - (T - T_o) e_bit

where the bit is the *last* degree of freedom, ``e_0`` the first one, and
``θ_p`` the perturbation of the prescribed (motor / surface) angle to which
the first DOF is tied (by a string element or by the Soft-Torque spring
``k_f`` and dash-pot ``c_f``).  Masses are in units of the reference mass
(BHA mass M for the SI models), inertias in units of I, stiffnesses in units of
M/t*² (axial) and C (torsional).  All matrices are tridiagonal (chains), stored
as ``(lower, diag, upper)`` rows.

Derivations
-----------
* Lumped chain (eqs 4.2.1, 4.3.1, 4.4.1, 5.1.1): mass i between springs k_i
  (above) and k_{i+1} (below): row i of K is ``[-k_i, k_i + k_{i+1}, -k_{i+1}]``;
  the top spring k_1 ties DOF 0 to the prescribed top (entry ``k^top = k_1``).
* Finite elements (App. A, re-derived): linear elements of length h on
  ``ρA U'' - (EA U')' = 0`` give ``K_e = EA/h [[1,-1],[-1,1]]`` and consistent
  ``M_e = ρAh/6 [[2,1],[1,2]]``; torsion likewise with GJ and ρJ.  Rayleigh
  damping ``C = η M + ϑ K`` in dimensionless units (ϑ multiplies the
  dimensionless stiffness, so it is a time in units of t*).  A prescribed top
  node is eliminated: its coupling column becomes ``k^top = -K_{10}``,
  ``c^top = -C_{10}``, ``m^top = -M_{10}``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .parameters import DrillStringSI, soft_torque_tuning
from .top_drive import kernel_drive

__all__ = ['max_stable_step', 'Chain', 'StringModel', 'lumped_chain', 'fem_chain', 'rgd', 'rgd_k',
           'axial_chain', 'coupled_chain', 'fem_drill_string', 'lumped_bha',
           'pipe_impedances']


@dataclass
class Chain:
    """One tridiagonal mass/damping/stiffness chain (axial or torsional).

    ``mass``, ``damping``, ``stiffness`` have shape (3, n): rows lower, diag,
    upper (``lower[0]`` and ``upper[-1]`` unused).  ``k_top``, ``c_top``,
    ``m_top`` couple DOF 0 to the prescribed top motion.  ``drive_node``: DOF 0 is the
    string's top node carrying the drive (Soft-Torque: the drive inertia on its spring),
    so the top-drive speed is that node's speed and the torque at the top of the string
    is the first element's; otherwise the top node is the prescribed motion itself.
    """

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    k_top: float = 0.0
    c_top: float = 0.0
    m_top: float = 0.0
    drive_node: bool = False

    @property
    def n(self) -> int:
        return self.mass.shape[1]

    def dense(self, which: str) -> np.ndarray:
        tri = getattr(self, which)
        n = self.n
        out = np.diag(tri[1])
        if n > 1:
            out += np.diag(tri[0, 1:], -1) + np.diag(tri[2, :-1], 1)
        return out


@dataclass
class StringModel:
    """A complete drill-string model: axial chain, torsional chain, bit scale.

    ``torsional`` may be ``None`` (axial-only chains of ch. 4: the bit turns at
    the imposed constant speed).  ``psi`` multiplies the bit force in the axial
    equation.  ``name`` is for reports.
    """

    name: str
    axial: Chain
    torsional: Chain | None
    psi: float
    #: delayed dash-pots on a single-mass bit (lumped model III):
    #: (axial coefficient, axial delay, torsional coefficient, torsional delay)
    delayed_damping: tuple | None = None
    #: finite-element strings: the length of each element [m], and elements per section
    element_lengths_m: np.ndarray | None = None
    section_elements: list | None = None
    #: a PI motor top drive on the torsional top node (:mod:`drill_twin.physics.top_drive`):
    #: its SI description and the kernel's dimensionless numbers (``kernel_drive``)
    top_drive: object | None = None
    motor_drive: dict | None = None


def _tri_from_dense(A: np.ndarray) -> np.ndarray:
    n = A.shape[0]
    tri = np.zeros((3, n))
    tri[1] = np.diag(A)
    if n > 1:
        tri[0, 1:] = np.diag(A, -1)
        tri[2, :-1] = np.diag(A, 1)
    return tri


def lumped_chain(masses, springs, damping=None, top_fixed=True) -> Chain:
    """Chain of point masses ``masses[i]`` joined by springs.

    ``springs[0]`` ties mass 0 to the prescribed top (ignored when
    ``top_fixed`` is False: free top, e.g. constant hook load), ``springs[i]``
    joins masses i-1 and i.  ``damping`` (optional) has the same layout as
    dash-pots.
    """
    m = np.asarray(masses, float)
    k = np.asarray(springs, float)
    n = m.size
    if k.size != n:
        raise ParameterError('need one spring per mass (springs[0] is the top spring)')
    if np.any(~np.isfinite(m)) or np.any(m <= 0):
        raise ParameterError('masses must be finite and > 0')
    c = np.zeros(n) if damping is None else np.asarray(damping, float)
    if np.any(~np.isfinite(k)) or np.any(k[1:] <= 0) or k[0] < 0:
        raise ParameterError('stiffnesses must be finite and > 0')
    if np.any(~np.isfinite(c)) or np.any(c < 0):
        raise ParameterError('dash-pot coefficients must be finite and >= 0')
    if top_fixed and k[0] == 0 and c[0] == 0:
        raise ParameterError('a prescribed top needs a spring or a dash-pot to the first mass')

    def tri(coef):
        t = np.zeros((3, n))
        top = coef[0] if top_fixed else 0.0
        t[1, 0] = top
        for i in range(1, n):
            t[1, i - 1] += coef[i]
            t[1, i] += coef[i]
            t[2, i - 1] = -coef[i]
            t[0, i] = -coef[i]
        return t

    M = np.zeros((3, n))
    M[1] = m
    return Chain(mass=M, damping=tri(c), stiffness=tri(k),
                 k_top=float(k[0]) if top_fixed else 0.0,
                 c_top=float(c[0]) if top_fixed else 0.0)


def fem_chain(element_lengths, stiffness_per_length, mass_per_length, eta, theta,
              top_fixed, top_mass=0.0, top_spring=0.0, top_dashpot=0.0,
              lumped=False, node_damping=None) -> Chain:
    """Linear finite elements with consistent (or lumped) mass and Rayleigh damping.

    Parameters
    ----------
    element_lengths : array (n_el,)
        Element lengths (any consistent unit; only products matter).
    stiffness_per_length : array (n_el,)
        EA (or GJ) of each element in units such that ``EA/h`` is the
        dimensionless element stiffness.
    mass_per_length : array (n_el,)
        ρA (or ρJ) of each element, so that ``ρA h`` is its dimensionless mass.
    eta, theta : float
        Rayleigh coefficients, ``C = eta*M + theta*K``.
    top_fixed : bool
        True: the top node is prescribed and eliminated.  False: it is free.
    top_mass, top_spring, top_dashpot : float
        Extra lumped mass on the top node and a spring/dash-pot tying it to
        the prescribed motion (the Soft-Torque drive).  Only for a free top.
    lumped : bool
        The row-sum (lumped) mass ``ρAh/2 [[1,0],[0,1]]`` per element instead of the
        consistent one: a diagonal mass, so that the wall's friction at a node acts on
        that node alone (docs/physics.md §9).
    node_damping : array (n_el + 1,), optional
        Viscous damping of every node (the mud's, per node: c ℓ_i), added to the
        diagonal of C.
    """
    h = np.asarray(element_lengths, float)
    ea = np.asarray(stiffness_per_length, float)
    ra = np.asarray(mass_per_length, float)
    n_nodes = h.size + 1
    K = np.zeros((n_nodes, n_nodes))
    M = np.zeros((n_nodes, n_nodes))
    for e in range(h.size):
        ke = ea[e] / h[e]
        me = ra[e] * h[e] / 6.0
        K[e:e + 2, e:e + 2] += ke * np.array([[1.0, -1.0], [-1.0, 1.0]])
        M[e:e + 2, e:e + 2] += me * (np.array([[3.0, 0.0], [0.0, 3.0]]) if lumped
                                     else np.array([[2.0, 1.0], [1.0, 2.0]]))
    M[0, 0] += top_mass
    C = eta * M + theta * K
    if node_damping is not None:
        C += np.diag(np.asarray(node_damping, float))
    K[0, 0] += top_spring
    C[0, 0] += top_dashpot
    if top_fixed:
        chain = Chain(mass=_tri_from_dense(M[1:, 1:]), damping=_tri_from_dense(C[1:, 1:]),
                      stiffness=_tri_from_dense(K[1:, 1:]), k_top=-K[1, 0],
                      c_top=-C[1, 0], m_top=-M[1, 0])
    else:
        chain = Chain(mass=_tri_from_dense(M), damping=_tri_from_dense(C),
                      stiffness=_tri_from_dense(K), k_top=top_spring, c_top=top_dashpot,
                      drive_node=top_mass > 0 or top_spring > 0)
    return chain


# --- the thesis's models ---------------------------------------------------------------

def rgd(psi: float) -> StringModel:
    """RGD model (eqs 4.1.1-4.1.2): mass on a constant hook load, torsional pendulum.

    Axial ``u'' = -ψ (W - W_o)``; torsional ``φ'' + φ = -(T - T_o)``.
    """
    return StringModel('rgd', lumped_chain([1.0], [0.0], top_fixed=False),
                       lumped_chain([1.0], [1.0]), float(psi))


def rgd_k(psi: float, kappa_d: float) -> StringModel:
    """RGD with an axial spring κ_d to an imposed surface axial velocity ([11], §4.1)."""
    return StringModel('rgd_k', lumped_chain([1.0], [kappa_d]),
                       lumped_chain([1.0], [1.0]), float(psi))


def _split(n: int, eps: float | None, eps2: float | None = None):
    """Mass (ε1) and stiffness (ε2) fractions of eq. 4.4.1 for N oscillators."""
    if n < 1:
        raise ParameterError(f'number of oscillators must be >= 1, got {n}')
    eps1 = 1.0 / n if eps is None else float(eps)
    eps2 = eps1 if eps2 is None else float(eps2)
    for name, e in (('eps', eps1), ('eps2', eps2)):
        if n > 1 and not 0.0 < (n - 1) * e < 1.0:
            raise ParameterError(f'{name} must satisfy 0 < (N-1)*{name} < 1, got {e}')
    mass = np.full(n, eps1)
    mass[-1] = 1.0 - (n - 1) * eps1
    compliance = np.full(n, eps2)
    compliance[-1] = 1.0 - (n - 1) * eps2
    return mass, compliance


def axial_chain(n: int, kappa_d: float, psi: float, eps: float | None = None,
                eps2: float | None = None, top_damping: float = 0.0) -> StringModel:
    """N axial oscillators of eqs 4.2.1 / 4.3.1 / 4.4.1 (constant rotation).

    Total mass 1 and total (series) stiffness κ_d are kept: masses ε1 (last
    1-(N-1)ε1), spring compliances ε2/κ_d (last (1-(N-1)ε2)/κ_d).  The top is
    an imposed axial velocity.  With time scaled so that the delay is 1, the
    1-DOF limit is ``u'' + p u' + a u - b u(t-1) = 0`` with ``a = κ_d + n_b ψ``,
    ``b = n_b ψ`` and ``p`` = ``top_damping`` (a dash-pot beside the top spring).
    """
    mass, compliance = _split(n, eps, eps2)
    damping = np.zeros(n)
    damping[0] = top_damping
    return StringModel(f'axial_chain_{n}', lumped_chain(mass, kappa_d / compliance, damping),
                       None, float(psi))


def coupled_chain(n: int, kappa_d: float, psi: float, axial_top: str = 'velocity') -> StringModel:
    """N identical axial + N identical torsional oscillators (RGD-2 for n=2, eq. 5.1.1).

    Masses M/N with springs N k, inertias I/N with springs N C, so the total
    mass, inertia and compliances are those of the RGD model.
    """
    mass, compliance = _split(n, None)
    top_fixed = axial_top == 'velocity'
    if axial_top not in ('velocity', 'hook_load'):
        raise ParameterError(f"axial_top must be 'velocity' or 'hook_load', got {axial_top!r}")
    return StringModel(f'coupled_chain_{n}',
                       lumped_chain(mass, kappa_d / compliance, top_fixed=top_fixed),
                       lumped_chain(mass, 1.0 / compliance), float(psi))


def section_elements(system: DrillStringSI, elements: int = 58,
                     bha_elements: int | None = None) -> list:
    """Finite elements of each section: a section's own ``elements`` if it has them, the
    BHA's ``bha_elements`` for the two-section string of the thesis, the rest shared out
    in proportion to length (at least one each)."""
    secs = system.sections
    fixed = [sec.elements for sec in secs]
    if bha_elements is not None and len(secs) == 2 and fixed[1] is None:
        fixed[1] = int(bha_elements)
    free = [i for i, n in enumerate(fixed) if n is None]
    left = elements - sum(n for n in fixed if n is not None)
    if free and left < len(free):
        raise ParameterError(f'model.elements = {elements} is too few for {len(secs)} '
                             'sections (at least one element each)')
    if free:
        lengths = np.array([secs[i].length_m for i in free])
        share = np.maximum(1, np.floor(left * lengths / lengths.sum()).astype(int))
        while share.sum() < left:  # largest remainders first
            share[np.argmax(left * lengths / lengths.sum() - share)] += 1
        while share.sum() > left:
            share[np.argmax(share)] -= 1
        for i, n in zip(free, share):
            fixed[i] = int(n)
    if any(n < 1 for n in fixed):
        raise ParameterError('every section needs at least one element')
    return fixed


def fem_drill_string(system: DrillStringSI, elements: int = 58, bha_elements: int | None = 10,
                     theta_u: float = 5e-4, theta_phi: float = 1e-4, eta_u: float = 0.0,
                     eta_phi: float = 0.0, top_drive: str = 'speed',
                     axial_top: str = 'hook_load', block_mass_kg: float = 0.0,
                     line_stiffness_N_m: float = 0.0, drive=None, lumped: bool = False,
                     mud_damping_N_s_m2: float = 0.0) -> StringModel:
    """Finite-element drill string of App. A / §3.2: every section of ``system`` meshed
    with linear elements of its own EA, GJ, ρA, ρJ.

    Axial top: ``'hook_load'`` (constant hook load, free node), ``'velocity'``
    (imposed block motion, node eliminated) or ``'hoist'`` (free node carrying the
    travelling block and hook mass on the drill line's stiffness, whose upper end —
    the drum — moves as commanded).  ``lumped``: lumped (diagonal) masses, as the wall
    friction of a deviated well needs (docs/physics.md §9); ``mud_damping_N_s_m2``: the
    mud's viscous drag per unit length and unit sliding speed c [N·s/m²], at every node
    c ℓ_i axially and c r² ℓ_i torsionally (ℓ_i its tributary length, r the pipe's
    outer radius).  Torsional top: ``'speed'`` (prescribed surface
    speed, node eliminated), ``'soft_torque'`` (drive inertia I_DS on the top node
    tied to the motor by the tuned k_f, c_f) or ``'motor'`` (the motor inertia of
    ``drive``, a :class:`~drill_twin.physics.top_drive.TopDrive`, on the top node, driven
    by its PI controller in the kernel).  Units: masses / M_BHA, inertias /
    I_BHA, stiffnesses / (M_BHA/t*²) and C.
    """
    if elements < 2:
        raise ParameterError('need elements >= 2')
    counts = section_elements(system, elements, bha_elements)
    s = system.scales()
    h, area, polar, rho, young, shear = [], [], [], [], [], []
    for sec, n in zip(system.sections, counts):
        h += [sec.length_m / n] * n
        area += [sec.area_m2] * n
        polar += [sec.polar_m4] * n
        rho += [sec.density_kg_m3] * n
        young += [sec.young_modulus_Pa] * n
        shear += [sec.shear_modulus_Pa] * n
    h, area, polar, rho, young, shear = map(np.asarray, (h, area, polar, rho, young, shear))
    t2 = s.time_s ** 2
    damp_a, damp_t = _mud_damping(system, counts, h, mud_damping_N_s_m2)
    if damp_a is not None:              # dimensionless: c t*/M and c t*/I
        damp_a, damp_t = damp_a * s.time_s / s.mass_kg, damp_t * s.time_s / s.inertia_kgm2
    if axial_top not in ('hook_load', 'velocity', 'hoist'):
        raise ParameterError(f"axial_top must be 'hook_load', 'velocity' or 'hoist', got "
                             f'{axial_top!r}')
    hoist = {}
    if axial_top == 'hoist':
        if not (block_mass_kg > 0 and line_stiffness_N_m > 0):
            raise ParameterError('a hoist needs the block mass and the drill line stiffness')
        hoist = {'top_mass': block_mass_kg / s.mass_kg,
                 'top_spring': line_stiffness_N_m * t2 / s.mass_kg}
    axial = fem_chain(h, young * area * t2 / s.mass_kg, rho * area / s.mass_kg, eta_u, theta_u,
                      top_fixed=axial_top == 'velocity', lumped=lumped, node_damping=damp_a,
                      **hoist)
    gj = shear * polar / s.torque_Nm
    rj = rho * polar / s.inertia_kgm2
    common = {'lumped': lumped, 'node_damping': damp_t}
    if top_drive == 'speed':
        tors = fem_chain(h, gj, rj, eta_phi, theta_phi, top_fixed=True, **common)
    elif top_drive == 'soft_torque':
        st = soft_torque_tuning(system.drive_inertia_kgm2 / s.inertia_kgm2)
        tors = fem_chain(h, gj, rj, eta_phi, theta_phi, top_fixed=False,
                         top_mass=st['inertia'], top_spring=st['stiffness'],
                         top_dashpot=st['damping'], **common)
    elif top_drive == 'motor':
        if drive is None:
            raise ParameterError("top_drive 'motor' needs the drive's description")
        tors = fem_chain(h, gj, rj, eta_phi, theta_phi, top_fixed=False,
                         top_mass=drive.motor_inertia_kgm2 / s.inertia_kgm2, **common)
    else:
        raise ParameterError(f"top_drive must be 'speed', 'soft_torque' or 'motor', got "
                             f'{top_drive!r}')
    model = StringModel(f'fem_{elements}', axial, tors, system.psi)
    if top_drive == 'motor':
        model.top_drive = drive
        model.motor_drive = kernel_drive(drive, system)
    model.element_lengths_m = h
    model.section_elements = counts
    return model


def _mud_damping(system, counts, h, c_N_s_m2):
    """Nodal viscous damping of the mud [N·s/m] axially and [N·m·s] torsionally: c ℓ_i and
    c r² ℓ_i, ℓ_i = half of each element beside node i; None without mud damping."""
    if not c_N_s_m2:
        return None, None
    if not (math.isfinite(c_N_s_m2) and c_N_s_m2 > 0.0):
        raise ParameterError(f'mud damping must be >= 0 N*s/m^2, got {c_N_s_m2!r}')
    radius = np.concatenate([[0.5 * sec.outer_diameter_m] * n
                             for sec, n in zip(system.sections, counts)])
    axial = np.zeros(h.size + 1)
    tors = np.zeros(h.size + 1)
    for share in (0, 1):                # each element's halves to its two nodes
        axial[share:h.size + share] += 0.5 * c_N_s_m2 * h
        tors[share:h.size + share] += 0.5 * c_N_s_m2 * radius ** 2 * h
    return axial, tors


def pipe_impedances(system: DrillStringSI) -> dict:
    """Radiation (semi-infinite pipe) impedances of the drill pipe just above the BHA,
    dimensionless.

    A semi-infinite elastic pipe loaded at its end answers a velocity V with the
    force ``A sqrt(Eρ) V`` (eqs 5.2.1-5.2.2: ∂U/∂t = -c ∂U/∂x), and a spin Ω with the
    torque ``J sqrt(Gρ) Ω``.  In units of M_BHA/t* and I/t* (the chain units):
    ``axial = A_d sqrt(Eρ) t*/M``, ``torsional = J_d sqrt(Gρ) t*/I``; also the wave
    round-trip times ``2 L_d/(c t*)`` along the pipe (units t*).
    """
    s = system.scales()
    pipe = system.pipe_sections[-1]
    rho, young, shear = pipe.density_kg_m3, pipe.young_modulus_Pa, pipe.shear_modulus_Pa
    z_u = pipe.area_m2 * math.sqrt(young * rho)
    z_p = pipe.polar_m4 * math.sqrt(shear * rho)
    # round trips over the whole pipe above the BHA, section by section
    t_u = sum(sec.length_m / math.sqrt(sec.young_modulus_Pa / sec.density_kg_m3)
              for sec in system.pipe_sections)
    t_p = sum(sec.length_m / math.sqrt(sec.shear_modulus_Pa / sec.density_kg_m3)
              for sec in system.pipe_sections)
    return {'axial': z_u * s.time_s / s.mass_kg, 'torsional': z_p * s.time_s / s.inertia_kgm2,
            'axial_round_trip': 2 * t_u / s.time_s, 'torsional_round_trip': 2 * t_p / s.time_s}


def lumped_bha(psi: float, variant: str, axial_impedance: float, torsional_impedance: float,
               kappa_d: float | None = None, delays: tuple | None = None) -> StringModel:
    """Lumped models of thesis App. B: a rigid BHA under a drill pipe.

    ``'I'``: the pipe is a semi-infinite radiation boundary both axially and
    torsionally (dash-pots of the pipe impedances to the nominal motion,
    eqs B.2.3-B.2.4).  ``'II'``: axially the pipe is the spring κ_d to an imposed
    surface velocity, torsionally still a radiation dash-pot (eqs B.2.5-B.2.6).
    ``'III'``: the pipe force is the radiation force of the bit velocity one
    wave round trip earlier, ``z_u u'(τ - τ_2)`` and ``z_φ φ'(τ - τ_3)``
    (eqs B.2.7-B.2.8, as printed), with ``τ_2 = 2L_d/(c_u t*)``,
    ``τ_3 = 2L_d/(c_φ t*)`` given in ``delays``.
    """
    if variant == 'III':
        if not delays or min(delays) <= 0:
            raise ParameterError('lumped model III needs positive wave round-trip delays')
        free = lumped_chain([1.0], [0.0], top_fixed=False)
        return StringModel('lumped_III', free, lumped_chain([1.0], [0.0], top_fixed=False),
                           float(psi), delayed_damping=(axial_impedance, delays[0],
                                                        torsional_impedance, delays[1]))
    tors = lumped_chain([1.0], [0.0], damping=[torsional_impedance])
    if variant == 'I':
        axial = lumped_chain([1.0], [0.0], damping=[axial_impedance])
    elif variant == 'II':
        if not kappa_d or kappa_d <= 0:
            raise ParameterError('lumped model II needs kappa_d > 0')
        axial = lumped_chain([1.0], [kappa_d])
    else:
        raise ParameterError(f"lumped model variant must be 'I', 'II' or 'III', got {variant!r}")
    return StringModel(f'lumped_{variant}', axial, tors, float(psi))


def max_stable_step(model: StringModel, cap: float = 5e-3) -> float:
    """Largest RK4 step (units t*, at most ``cap``) for the delay-free chain operators.

    Every eigenvalue μ of ``[[0, I], [-M⁻¹K, -M⁻¹C]]`` (each chain) must satisfy
    ``|R(hμ)| <= 1`` with the RK4 stability function R.  Stiffness-proportional
    damping puts the fastest modes near the negative real axis, so the
    imaginary-axis bound 2.83/ω_max alone is not enough.  Found by bisection on
    h (dense eigenvalues: O(n³), ~1 s for 1000 elements, computed once per model
    and kept on it, since a scenario with ``time_step: auto`` and the Simulation
    built from it both ask).  A motor drive's PI loop counts as its linear equivalent, the
    spring K_i and dash-pot K_p on the top node (torque feedback and limit aside).
    """
    mu = model.__dict__.get('_chain_eigenvalues')
    if mu is None:
        mus = []
        for chain in (model.axial, model.torsional):
            if chain is None:
                continue
            n = chain.n
            Minv = np.linalg.inv(chain.dense('mass'))
            K, C = chain.dense('stiffness'), chain.dense('damping')
            if chain is model.torsional and model.motor_drive:
                K[0, 0] += model.motor_drive['ki']
                C[0, 0] += model.motor_drive['kp']
            A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
            mus.append(np.linalg.eigvals(A))
        mu = np.concatenate(mus)
        # eigen-solver noise can put undamped or rigid-body modes a hair right of the axis
        mu = np.minimum(mu.real, 0.0) + 1j * mu.imag
        model.__dict__['_chain_eigenvalues'] = mu

    def stable(h):
        z = h * mu
        return bool(np.all(np.abs(1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24) <= 1 + 1e-9))
    if stable(cap):
        return cap
    lo, hi = 0.0, cap
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return lo
