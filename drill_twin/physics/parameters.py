"""Drilling-system parameters, characteristic scales and dimensionless groups.

Everything dimensionless in drill_twin is *derived here, in code*, from one
consistent SI parameter set (or given directly for the dimensionless research
configurations of thesis chapters 4-5).  See ``docs/parameters.md`` for the
resolution of the inconsistencies of thesis Table D.1.1.

Derivation (thesis §2.2-2.4, re-derived from momentum balance)
---------------------------------------------------------------
Bit/rock law of Detournay & Defourny (eqs 2.2.6-2.2.9), ``d`` depth of cut per
blade, ``g`` the wear-flat contact indicator (1 while the bit moves down):

    W = n_b ζ ε a d + n_b a ℓ σ_f g ,     T = ½ n_b ε a² d + ½ n_b a² μ γ ℓ σ_f g .

Torsional pendulum of the RGD model, ``I Φ'' + C (Φ - Ω_o t) = -T``.  Dividing
by ``C`` and scaling time by ``t* = sqrt(I/C)`` (eq. 2.4.1) gives
``Φ'' + (Φ - ω_o τ) = -T/C`` with

    T/C = n_b d / d* + n_b λ β g ,    d* = 2C/(ε a²),  λ = ℓ a² σ_f/(2 ζ C),  β = μ γ ζ.

So the torque unit that makes eq. 2.4.6 (T_o = n_b(δ_o + λβ)) true is ``C``
(N·m per radian), i.e. ``T* = ζ C`` of eq. 2.4.1 differs from it by ``ζ``: we use
``torque_scale = C`` and say so.  The axial balance of a mass ``M`` under a
constant hook load, ``M U'' = W_o - W``, scaled by ``d*`` and ``t*`` gives
``u'' = ψ (W_o - W)/W*`` with ``W* = ζ ε a d* = 2 ζ C / a`` and
``ψ = ζ ε a t*² / M`` (the axial/torsional time-scale ratio of the RGD model).

Steady state (eqs 2.3.6, 2.4.5, 2.4.6): constant Ω_o, constant V_o, all blades
see the same depth of cut ``δ_o = (W_o - n_b λ)/n_b`` (only if W_o > n_b λ),
``υ_o = n_b δ_o ω_o /(2π)``, ``τ_1,0 = 2π/(n_b ω_o)``,
``T_o = n_b (δ_o + λ β)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

from ..errors import ParameterError

__all__ = [
    'BitRockGroups', 'DrillStringSI', 'StringSection', 'Scales',
    'steady_state', 'soft_torque_tuning', 'soft_torque_si', 'GRAVITY_M_S2',
]


def checked_number(name: str, value, low: float | None = None,
                   open_low: bool = False) -> float:
    """``value`` as a finite float, at least ``low`` (above it with ``open_low``); else one
    :class:`~drill_twin.errors.ParameterError` line naming ``name``: the one check of a
    physical number's type, finiteness and lower bound."""
    try:
        value = float(value)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f'{name} must be a number, got {value!r}') from exc
    if not math.isfinite(value):
        raise ParameterError(f'{name} must be finite, got {value!r}')
    if low is not None and (value < low or (open_low and value == low)):
        raise ParameterError(f"{name} must be {'>' if open_low else '>='} {low:g}, "
                             f'got {value!r}')
    return value


def _check_positive(name: str, value: float, allow_zero: bool = False) -> float:
    return checked_number(name, value, 0.0, open_low=not allow_zero)


@dataclass(frozen=True)
class BitRockGroups:
    """Dimensionless groups of the bit/rock interface at one operating point.

    Parameters
    ----------
    n_b : int
        Number of blades (>= 1).
    lam : float
        Bluntness number λ (eq. 2.4.4); ``n_b*lam`` is the dimensionless
        wear-flat contact force.
    beta : float
        Bit/rock interaction number β = μγζ (eq. 2.4.4).
    W_o : float
        Dimensionless weight on bit W_o/W* (eq. 2.4.6).  Must exceed ``n_b*lam``
        (eq. 2.3.6: otherwise all weight is taken by friction, no drilling).
    omega_o : float
        Dimensionless surface/bit angular speed Ω_o t* (eq. 2.4.5).
    psi : float
        Axial force scale ψ: the bit-force coefficient of the axial equation
        of motion, normalised by the reference (BHA) mass.
    blade_angles : tuple of float
        Angular positions of the n_b blades [rad]; empty for evenly spaced blades
        (pitch 2π/n_b, the thesis's bit).  With uneven blades each blade cuts the
        rock left by the blade ahead of it, one gap earlier (§6.2).
    """

    n_b: int
    lam: float
    beta: float
    W_o: float
    omega_o: float
    psi: float
    blade_angles: tuple = ()

    def __post_init__(self):
        if isinstance(self.n_b, float) and not float(self.n_b).is_integer():
            raise ParameterError(f'n_b must be an integer number of blades, got {self.n_b!r}')
        if not isinstance(self.n_b, (int, float)) or self.n_b < 1:
            raise ParameterError(f'n_b must be >= 1, got {self.n_b!r}')
        object.__setattr__(self, 'n_b', int(self.n_b))
        _check_positive('lam', self.lam, allow_zero=True)
        _check_positive('beta', self.beta, allow_zero=True)
        _check_positive('omega_o', self.omega_o)
        _check_positive('psi', self.psi)
        _check_positive('W_o', self.W_o)
        if self.W_o <= self.n_b * self.lam:
            raise ParameterError(
                f'W_o = {self.W_o:g} does not exceed the wear-flat friction threshold '
                f'n_b*lam = {self.n_b * self.lam:g} (eq. 2.3.6): the bit does not drill')
        if self.blade_angles:
            angles = tuple(float(a) for a in self.blade_angles)
            if len(angles) != self.n_b:
                raise ParameterError(f'{len(angles)} blade angles for n_b = {self.n_b} blades')
            if not all(math.isfinite(a) for a in angles):
                raise ParameterError('blade angles must be finite')
            wrapped = sorted(a % (2 * math.pi) for a in angles)
            gaps = [b - a for a, b in zip(wrapped, wrapped[1:])] + \
                [wrapped[0] + 2 * math.pi - wrapped[-1]]
            if min(gaps) <= 1e-6:
                raise ParameterError('two blades at the same angle')
            object.__setattr__(self, 'blade_angles', tuple(wrapped))

    # --- the bit's blades on the rock --------------------------------------------------
    @property
    def uneven(self) -> bool:
        """True when the blades are not evenly spaced."""
        if not self.blade_angles:
            return False
        return max(self.blade_gaps) - min(self.blade_gaps) > 1e-12

    @property
    def blade_gaps(self) -> tuple:
        """Angle from each blade to the blade ahead of it (the one that cut its rock
        last) [rad]; all 2π/n_b for an even bit."""
        if not self.blade_angles:
            return (2.0 * math.pi / self.n_b,) * self.n_b
        a = self.blade_angles
        return tuple((a[(i + 1) % len(a)] - a[i]) % (2 * math.pi) or 2 * math.pi
                     for i in range(len(a)))

    @property
    def blade_delays(self) -> tuple:
        """Steady delay of each blade, gap/ω_o (all τ_1,0 for an even bit)."""
        return tuple(g / self.omega_o for g in self.blade_gaps)

    @property
    def min_delay(self) -> float:
        """Shortest steady delay (the step must resolve it)."""
        return min(self.blade_delays)

    # --- steady state, eqs 2.3.6, 2.4.5, 2.4.6 -------------------------------------
    @property
    def delta_o(self) -> float:
        """Steady depth of cut per blade δ_o = (W_o - n_b λ)/n_b (eq. 2.4.6)."""
        return (self.W_o - self.n_b * self.lam) / self.n_b

    @property
    def upsilon_o(self) -> float:
        """Steady axial speed υ_o = ω_o (W_o - n_b λ)/(2π) (eq. 2.4.5)."""
        return self.omega_o * (self.W_o - self.n_b * self.lam) / (2.0 * math.pi)

    @property
    def T_o(self) -> float:
        """Steady torque on bit T_o = n_b (δ_o + λβ) in units of C (eq. 2.4.6)."""
        return self.n_b * (self.delta_o + self.lam * self.beta)

    @property
    def tau_10(self) -> float:
        """Steady delay τ_1,0 = 2π/(n_b ω_o) (eq. 2.4.5)."""
        return 2.0 * math.pi / (self.n_b * self.omega_o)

    @property
    def alpha_o(self) -> float:
        """Ratio α_o = υ_o/ω_o that couples delay and axial motion (§5.1)."""
        return self.upsilon_o / self.omega_o

    def replace(self, **changes) -> BitRockGroups:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update(changes)
        return BitRockGroups(**values)


def steady_state(groups: BitRockGroups) -> dict:
    """Steady drilling state (eqs 2.3.6, 2.4.5, 2.4.6) as a dict of floats."""
    return {'delta_o': groups.delta_o, 'upsilon_o': groups.upsilon_o, 'W_o': groups.W_o,
            'T_o': groups.T_o, 'tau_10': groups.tau_10, 'alpha_o': groups.alpha_o,
            'omega_o': groups.omega_o}


@dataclass(frozen=True)
class Scales:
    """Characteristic quantities of eq. 2.4.1 (SI).

    Attributes
    ----------
    time_s : t* = sqrt(I/C) [s]
    depth_m : d* = 2C/(εa²) [m]
    force_N : W* = ζ ε a d* [N]
    torque_Nm : C, the torque per radian that makes eq. 2.4.6 exact [N·m]
    mass_kg : reference mass (BHA mass) [kg]
    inertia_kgm2 : reference polar inertia I (BHA) [kg·m²]
    """

    time_s: float
    depth_m: float
    force_N: float
    torque_Nm: float
    mass_kg: float
    inertia_kgm2: float

    @property
    def speed_m_s(self) -> float:
        return self.depth_m / self.time_s


GRAVITY_M_S2 = 9.81


@dataclass(frozen=True)
class StringSection:
    """One section of the drill string (drill pipe, heavy-weight pipe, collars ...), SI.

    ``bha``: the section belongs to the bottom-hole assembly (its inertia and mass are
    the reference I and M of the scales, eq. 2.4.1); ``elements``: finite elements of
    this section (None: shared out by length, :func:`drill_twin.physics.models.fem_drill_string`).
    """

    name: str
    length_m: float
    outer_diameter_m: float
    inner_diameter_m: float
    density_kg_m3: float
    young_modulus_Pa: float
    shear_modulus_Pa: float
    bha: bool = False
    elements: int | None = None

    def __post_init__(self):
        for f in ('length_m', 'outer_diameter_m', 'density_kg_m3', 'young_modulus_Pa',
                  'shear_modulus_Pa'):
            _check_positive(f'section {self.name!r} {f}', getattr(self, f))
        _check_positive(f'section {self.name!r} inner_diameter_m', self.inner_diameter_m,
                        allow_zero=True)
        if self.inner_diameter_m >= self.outer_diameter_m:
            raise ParameterError(f'section {self.name!r}: inner_diameter_m '
                                 f'{self.inner_diameter_m:g} m must be below outer_diameter_m '
                                 f'{self.outer_diameter_m:g} m')

    @property
    def area_m2(self) -> float:
        return math.pi / 4.0 * (self.outer_diameter_m ** 2 - self.inner_diameter_m ** 2)

    @property
    def polar_m4(self) -> float:
        return math.pi / 32.0 * (self.outer_diameter_m ** 4 - self.inner_diameter_m ** 4)

    @property
    def mass_kg(self) -> float:
        return self.density_kg_m3 * self.area_m2 * self.length_m

    @property
    def inertia_kgm2(self) -> float:
        """Polar mass moment of inertia ρ J L [kg·m²]."""
        return self.density_kg_m3 * self.polar_m4 * self.length_m

    @property
    def torsional_compliance(self) -> float:
        """L / (G J) [rad/(N·m)]."""
        return self.length_m / (self.shear_modulus_Pa * self.polar_m4)

    @property
    def axial_compliance(self) -> float:
        """L / (E A) [m/N]."""
        return self.length_m / (self.young_modulus_Pa * self.area_m2)

    def buoyed_weight_N(self, mud_density_kg_m3: float) -> float:
        """Weight in mud, (ρ - ρ_mud) g A L [N]."""
        return (self.density_kg_m3 - mud_density_kg_m3) * GRAVITY_M_S2 * self.area_m2 \
            * self.length_m


@dataclass(frozen=True)
class DrillStringSI:
    """One consistent SI description of a drilling system (thesis App. D, §2.2.1).

    All lengths in m, areas in m², polar second moments in m⁴, moduli and
    stresses in Pa, densities in kg/m³, masses in kg, speeds in rad/s,
    forces in N.  The string is ``sections`` (top to bottom; :class:`StringSection`),
    each with its own OD, ID, length and material; given none, it is the thesis's
    two sections, drill pipe over BHA, from the ``pipe_*``/``bha_*`` fields (radii).
    With sections given, those fields are set to their summary: the lengths of the
    pipe above the BHA and of the BHA, the radii of the section just above the BHA
    and of the first BHA section.  Scales (eq. 2.4.1) come from the sections:
    I and M of the BHA, C the series torsional stiffness of the pipe above it.
    """

    pipe_length_m: float = 1000.0
    bha_length_m: float = 200.0
    pipe_outer_radius_m: float = 0.0635
    pipe_inner_radius_m: float = 0.053975
    bha_outer_radius_m: float = 0.0762
    bha_inner_radius_m: float = 0.0286
    density_kg_m3: float = 8000.0
    young_modulus_Pa: float = 200e9
    shear_modulus_Pa: float = 77e9
    bit_radius_m: float = 0.10795
    blades: int = 6
    intrinsic_specific_energy_Pa: float = 60e6
    contact_stress_Pa: float = 60e6
    wear_flat_length_m: float = 1.3e-3
    cutting_force_ratio_zeta: float = 0.6
    friction_coefficient_mu: float = 0.6
    bit_geometry_gamma: float = 1.0
    drive_mass_kg: float = 18160.0
    drive_width_m: float = 1.867
    drive_depth_m: float = 1.722
    mud_density_kg_m3: float = 1200.0
    sections: tuple = ()
    blade_angles_rad: tuple = ()
    extra: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        for f in fields(self):
            if f.name in ('extra', 'blades', 'sections', 'blade_angles_rad'):
                continue
            _check_positive(f.name, getattr(self, f.name),
                            allow_zero=f.name == 'mud_density_kg_m3')
        if int(self.blades) != self.blades or self.blades < 1:
            raise ParameterError(f'blades must be an integer >= 1, got {self.blades!r}')
        if not self.sections:
            if self.pipe_inner_radius_m >= self.pipe_outer_radius_m:
                raise ParameterError('pipe_inner_radius_m must be smaller than '
                                     'pipe_outer_radius_m')
            if self.bha_inner_radius_m >= self.bha_outer_radius_m:
                raise ParameterError('bha_inner_radius_m must be smaller than '
                                     'bha_outer_radius_m')
            object.__setattr__(self, 'sections', (
                StringSection('drill pipe', self.pipe_length_m, 2 * self.pipe_outer_radius_m,
                              2 * self.pipe_inner_radius_m, self.density_kg_m3,
                              self.young_modulus_Pa, self.shear_modulus_Pa),
                StringSection('BHA', self.bha_length_m, 2 * self.bha_outer_radius_m,
                              2 * self.bha_inner_radius_m, self.density_kg_m3,
                              self.young_modulus_Pa, self.shear_modulus_Pa, bha=True)))
        else:
            self._summarise_sections()
        for sec in self.sections:
            if self.mud_density_kg_m3 >= sec.density_kg_m3:
                raise ParameterError(f'mud density {self.mud_density_kg_m3:g} kg/m^3 must be '
                                     f'below the density of section {sec.name!r}')

    def _summarise_sections(self):
        secs = tuple(self.sections)
        if not all(isinstance(sec, StringSection) for sec in secs):
            raise ParameterError('sections must be StringSection objects')
        if not any(sec.bha for sec in secs):
            secs = secs[:-1] + (replace(secs[-1], bha=True),)  # the last one is the BHA
        first_bha = next(i for i, sec in enumerate(secs) if sec.bha)
        if first_bha == 0 or not all(sec.bha for sec in secs[first_bha:]):
            raise ParameterError('the BHA sections must be the lowest ones, below at least one '
                                 'section of pipe')
        pipe, bha = secs[first_bha - 1], secs[first_bha]
        set_ = object.__setattr__
        set_(self, 'sections', secs)
        set_(self, 'pipe_length_m', sum(sec.length_m for sec in secs[:first_bha]))
        set_(self, 'bha_length_m', sum(sec.length_m for sec in secs[first_bha:]))
        set_(self, 'pipe_outer_radius_m', pipe.outer_diameter_m / 2)
        set_(self, 'pipe_inner_radius_m', pipe.inner_diameter_m / 2)
        set_(self, 'bha_outer_radius_m', bha.outer_diameter_m / 2)
        set_(self, 'bha_inner_radius_m', bha.inner_diameter_m / 2)

    # --- section properties -------------------------------------------------------
    @property
    def pipe_sections(self) -> tuple:
        return tuple(sec for sec in self.sections if not sec.bha)

    @property
    def bha_sections(self) -> tuple:
        return tuple(sec for sec in self.sections if sec.bha)

    @property
    def total_length_m(self) -> float:
        return sum(sec.length_m for sec in self.sections)

    @property
    def pipe_area_m2(self):
        """Area of the pipe section just above the BHA (the one waves radiate into)."""
        return self.pipe_sections[-1].area_m2

    @property
    def bha_area_m2(self):
        return self.bha_sections[0].area_m2

    @property
    def pipe_polar_m4(self):
        return self.pipe_sections[-1].polar_m4

    @property
    def bha_polar_m4(self):
        return self.bha_sections[0].polar_m4

    @property
    def bha_mass_kg(self):
        return sum(sec.mass_kg for sec in self.bha_sections)

    @property
    def bha_inertia_kgm2(self):
        """BHA polar mass moment of inertia I = Σ ρ J L [kg·m²]."""
        return sum(sec.inertia_kgm2 for sec in self.bha_sections)

    @property
    def pipe_torsional_stiffness_Nm(self):
        """Torsional stiffness of the pipe above the BHA, C = 1/Σ L/(G J) [N·m/rad]
        (eq. 2.4.1: G J_d / L_d for one section)."""
        return 1.0 / sum(sec.torsional_compliance for sec in self.pipe_sections)

    @property
    def pipe_axial_stiffness_N_m(self):
        """Axial stiffness of the pipe above the BHA, 1/Σ L/(E A) [N/m]."""
        return 1.0 / sum(sec.axial_compliance for sec in self.pipe_sections)

    @property
    def drive_inertia_kgm2(self):
        """Top-drive inertia I_DS = M_DS (l1² + l2²)/12 [kg·m²] (§2.2.1)."""
        return self.drive_mass_kg * (self.drive_width_m ** 2 + self.drive_depth_m ** 2) / 12.0

    def buoyed_weight_N(self, mud_density_kg_m3: float | None = None,
                        gravity_m_s2: float = GRAVITY_M_S2) -> float:
        """Buoyed weight of the whole string ∫ f_u dx [N] (§2.1: H = ∫ f_u dx - W), in the
        configured mud unless ``mud_density_kg_m3`` is given."""
        mud = self.mud_density_kg_m3 if mud_density_kg_m3 is None else mud_density_kg_m3
        _check_positive('mud_density_kg_m3', mud, allow_zero=True)
        if any(mud >= sec.density_kg_m3 for sec in self.sections):
            raise ParameterError('mud density must be below the steel density')
        return sum(sec.buoyed_weight_N(mud) for sec in self.sections) \
            * gravity_m_s2 / GRAVITY_M_S2

    # --- characteristic scales, eq. 2.4.1 ---------------------------------------
    def scales(self) -> Scales:
        C = self.pipe_torsional_stiffness_Nm
        inertia = self.bha_inertia_kgm2
        t_star = math.sqrt(inertia / C)
        d_star = 2.0 * C / (self.intrinsic_specific_energy_Pa * self.bit_radius_m ** 2)
        W_star = self.cutting_force_ratio_zeta * self.intrinsic_specific_energy_Pa \
            * self.bit_radius_m * d_star
        return Scales(time_s=t_star, depth_m=d_star, force_N=W_star, torque_Nm=C,
                      mass_kg=self.bha_mass_kg, inertia_kgm2=inertia)

    @property
    def lam(self) -> float:
        """Bluntness number λ = ℓ a² σ_f /(2 ζ C) (eq. 2.4.4)."""
        return (self.wear_flat_length_m * self.bit_radius_m ** 2 * self.contact_stress_Pa
                / (2.0 * self.cutting_force_ratio_zeta * self.pipe_torsional_stiffness_Nm))

    @property
    def beta(self) -> float:
        """β = μ γ ζ (eq. 2.4.4)."""
        return self.friction_coefficient_mu * self.bit_geometry_gamma \
            * self.cutting_force_ratio_zeta

    @property
    def psi(self) -> float:
        """ψ = ζ ε a t*² / M_BHA: axial bit-force coefficient for the BHA mass."""
        s = self.scales()
        return s.force_N * s.time_s ** 2 / (s.mass_kg * s.depth_m)

    @property
    def kappa_d(self) -> float:
        """κ_d = t*² E A_d /(L_d M_BHA): squared ratio of t* to the pipe axial period."""
        s = self.scales()
        return s.time_s ** 2 * self.pipe_axial_stiffness_N_m / s.mass_kg

    def groups(self, surface_speed_rad_s: float, weight_on_bit_N: float) -> BitRockGroups:
        """Dimensionless groups at an operating point (Ω_o [rad/s], W_o [N])."""
        _check_positive('surface_speed_rad_s', surface_speed_rad_s)
        _check_positive('weight_on_bit_N', weight_on_bit_N)
        s = self.scales()
        return BitRockGroups(n_b=int(self.blades), lam=self.lam, beta=self.beta,
                             W_o=weight_on_bit_N / s.force_N,
                             omega_o=surface_speed_rad_s * s.time_s, psi=self.psi,
                             blade_angles=tuple(self.blade_angles_rad))


def soft_torque_tuning(drive_inertia_ratio: float) -> dict:
    """Soft-Torque spring and dash-pot in dimensionless form (§3.2, after [37]).

    The drive (inertia ``I_DS``) on its spring ``k_f`` is tuned to the string's
    first torsional frequency 1/t*: ``k_f = I_DS/t*²``.  With
    ``Γ = I/I_DS`` the optimal damping ratio is ``ξ_opt = sqrt(Γ/2)`` and
    the dash-pot is ``c_f = 2 ξ_opt sqrt(k_f I_DS) = 2 ξ_opt I_DS/t*``.  (The
    printed ``c_f = I_DS/2ξ_opt`` is dimensionally wrong.)  In units of ``C`` and
    ``t*`` (inertias divided by the BHA inertia ``I``):

    Parameters
    ----------
    drive_inertia_ratio : float
        I_DS / I (dimensionless).

    Returns
    -------
    dict with ``inertia`` (I_DS/I), ``stiffness`` (k_f/C), ``damping``
    (c_f/(C t*)), ``xi_opt``.
    """
    r = _check_positive('drive_inertia_ratio', drive_inertia_ratio)
    xi = math.sqrt(1.0 / r / 2.0)
    return {'inertia': r, 'stiffness': r, 'damping': 2.0 * xi * r, 'xi_opt': xi}


def soft_torque_si(system: DrillStringSI, drive_inertia_kgm2: float | None = None) -> dict:
    """:func:`soft_torque_tuning` in SI for the string ``system``: I_DS [kg m²] (the
    §2.2.1 drive unless given), k_f [N m/rad], c_f [N m s/rad], ξ_opt.  The
    dimensionless values times the scales: inertias × I, stiffness × I/t*², damping ×
    I/t*."""
    s = system.scales()
    I_ds = system.drive_inertia_kgm2 if drive_inertia_kgm2 is None else drive_inertia_kgm2
    tuning = soft_torque_tuning(I_ds / s.inertia_kgm2)
    return {'inertia': I_ds, 'stiffness': tuning['stiffness'] * s.inertia_kgm2 / s.time_s ** 2,
            'damping': tuning['damping'] * s.inertia_kgm2 / s.time_s,
            'xi_opt': tuning['xi_opt']}
