"""Materials: elastic constants, density and internal damping.

A :class:`Material` holds Young's modulus ``young`` (Pa), ``density`` (kg/m^3),
Poisson's ratio ``poisson`` (dimensionless, in (-1, 0.5)) and an internal damping
law (:class:`Rayleigh` or :class:`LossFactor`) that sets the decay rate of a
plate's bending modes (docs/physics.md, "Materials").

The built-in table :data:`TABLE` has a cited source for every row; look a row
up with :func:`get` (case-insensitive) and print it with :func:`table_markdown`.
Any :class:`Material` can also be built by hand.

Where the numbers come from
---------------------------
* Thesis rows (``mdf-18``, ``mdf-12``, ``mdf-6``, ``steel``, ``glass``): the
  Table 3.1 of the thesis (docs/physics.md, "Materials" and References). The MDF moduli were
  measured on the three boards; their Rayleigh damping is the fit to the thesis' recordings
  (docs/physics.md, "Materials").
* Handbook rows: the elastic constants and the loss factor of one printed row
  of one of these tables, unless the row's ``source`` says otherwise:

  - Cremer, Heckl & Petersson, *Structure-Borne Sound*, 3rd ed. (Springer
    2005), Table 4.3 (metals; flexural loss factors, as ranges);
  - Bies, Hansen & Howard, *Engineering Noise Control*, 5th ed. (CRC Press
    2017), Appendix C, Table C.1 (its loss-factor column prints two numbers:
    the lower is the material's own, the upper a panel built into a building;
    the lower is used here);
  - Hopkins, *Sound Insulation* (Butterworth-Heinemann 2007), Table A2 (it
    prints the quasi-longitudinal plate speed ``c_L`` instead of ``E``; the row
    then takes ``E = c_L**2 * rho * (1 - nu**2)``);
  - Mechel (ed.), *Formulas of Acoustics*, 2nd ed. (Springer 2008), the
    material table "Table 3", pp. 529-530;
  - Vigran, *Building Acoustics* (Taylor & Francis 2008), Table 3.1;
  - Norton & Karczub, *Fundamentals of Noise and Vibration Analysis for
    Engineers*, 2nd ed. (Cambridge UP 2003), Table 6.1 (loss factors only);
  - granite: Leet & Ewing, "Velocity of elastic waves in granite", Physics 2,
    160 (1932) for the elastic constants, and Birch & Bancroft, "Elasticity and
    internal friction in a long column of granite", Bull. Seismol. Soc. Am. 28,
    243 (1938) for the damping (Q = 150 at 140-4500 Hz, so ``eta = 1/Q``).

  - Ashby, *Materials Selection in Mechanical Design*, 4th ed.
    (Butterworth-Heinemann 2011): ABS and porcelain, whose loss factors are read
    off its loss coefficient-modulus chart (an order of magnitude, not a
    measurement of one grade);
  - Kingery, Bowen & Uhlmann, *Introduction to Ceramics*, 2nd ed. (Wiley 1976):
    porcelain's modulus.

Loss factors are those of bending waves at audio frequencies. They are the
least certain column of any such table: the handbooks give ranges or single
"representative" values, and a metal's loss factor depends on its working and
heat treatment (Cremer et al. section 4.5.1). Where the books disagree the row's
``source`` says which value was taken and names the others.

Woods are orthotropic; the table gives the modulus along the grain (the handbook
value), which overstates the stiffness of a board bent across the grain.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from synth import checks
from synth.errors import ParameterError

#: Young's modulus a material may have, Pa (closed interval): from the softest solid
#: elastomers, solvent-free bottlebrush networks of a modulus of order 100 Pa (Daniel et
#: al., "Solvent-free, supersoft and superelastic bottlebrush melts and networks",
#: Nature Materials 15, 183 (2016)), to diamond, the stiffest bulk solid, 1.05 to
#: 1.21 TPa along its crystal axes (Klein & Cardinale, "Young's modulus and Poisson's
#: ratio of CVD diamond", Diamond and Related Materials 2, 918 (1993)). Outside it a
#: value is a typing error (a unit: GPa for Pa), not a solid.
YOUNG_RANGE = (100.0, 1.21e12)

#: Density a material may have, kg/m^3 (closed interval): from the lightest solids,
#: graphene aerogels of 0.16 kg/m^3 (Sun, Xu & Gao, "Multifunctional, ultra-flyweight,
#: synergistically assembled carbon aerogels", Advanced Materials 25, 2554 (2013)), to
#: osmium, the densest element, 22 590 kg/m^3 at room temperature (CRC Handbook of
#: Chemistry and Physics, "Density of the elements"; Arblaster, Platinum Metals Rev. 33,
#: 14 (1989): 22 587).
DENSITY_RANGE = (0.16, 22_590.0)


def _solid_value(name: str, value, bounds: tuple[float, float], unit: str, what: str) -> float:
    """``value`` checked to lie in ``bounds`` (closed), else a ParameterError naming
    ``name``, the value, the interval and ``what`` bounds it."""
    lo, hi = bounds
    x = checks.real(name, value, unit, f"in [{lo:g}, {hi:g}]")
    if not lo <= x <= hi:
        raise ParameterError(f"{name}={value!r} must be in [{lo:g}, {hi:g}] {unit} ({what})")
    return x


@dataclass(frozen=True)
class Rayleigh:
    """Rayleigh damping: modal decay rate ``sigma = alpha/2 + beta * omega**2 / 2``.

    Parameters
    ----------
    alpha : float >= 0
        Mass-proportional coefficient, 1/s.
    beta : float >= 0
        Stiffness-proportional coefficient, s.
    """

    alpha: float
    beta: float

    def __post_init__(self):
        object.__setattr__(self, "alpha", checks.nonnegative("damping.alpha", self.alpha, "1/s"))
        object.__setattr__(self, "beta", checks.nonnegative("damping.beta", self.beta, "s"))

    def decay_rate(self, omega) -> np.ndarray:
        """Amplitude decay rate sigma (1/s) at angular frequency ``omega`` (rad/s)."""
        omega = np.asarray(omega, dtype=float)
        return 0.5 * self.alpha + 0.5 * self.beta * omega * omega


@dataclass(frozen=True)
class LossFactor:
    """Constant loss factor: modal decay rate ``sigma = eta * omega / 2``.

    Parameters
    ----------
    eta : float in [0, 1)
        Loss factor (dimensionless).
    """

    eta: float

    def __post_init__(self):
        object.__setattr__(
            self,
            "eta",
            checks.in_range("damping.eta", self.eta, 0.0, 1.0, "dimensionless", lo_open=False),
        )

    def decay_rate(self, omega) -> np.ndarray:
        """Amplitude decay rate sigma (1/s) at angular frequency ``omega`` (rad/s)."""
        return 0.5 * self.eta * np.asarray(omega, dtype=float)


Damping = Rayleigh | LossFactor


@dataclass(frozen=True)
class Material:
    """An elastic material: isotropic, or transversely isotropic with its own transverse
    shear modulus (a board whose through-thickness direction is softer than its plane).

    Parameters
    ----------
    name : str
        Name used in messages and presets.
    density : float in DENSITY_RANGE
        Mass density, kg/m^3 (:data:`DENSITY_RANGE`: aerogel to osmium).
    young : float in YOUNG_RANGE
        Young's modulus, Pa (:data:`YOUNG_RANGE`: the softest elastomers to diamond).
    poisson : float in (-1, 0.5)
        Poisson's ratio, dimensionless.
    damping : Rayleigh or LossFactor or None
        Internal damping law of the material's bending modes. Needed for a plate
        (its modes decay by it); a ball's material may leave it out (None).
    source : str
        Where the values come from (citation), for table rows.
    transverse_shear : float > 0 or None
        Transverse shear modulus ``G_t`` (Pa): the shear of planes across the thickness that
        a thick (Mindlin) plate's bending strains (docs/physics.md, "Thick plates (Mindlin)").
        None: isotropic, ``G = E / (2 (1 + nu))``. Only the Mindlin plate reads it; the thin
        plate, the modes and the contact do not.
    yield_stress : float > 0 or None
        Uniaxial yield stress ``Y`` (Pa) of a ductile material: a plastic contact holds
        the hardness ``2.8 Y`` (docs/physics.md, "Yield of the contact").
        None: no plastic yield (a brittle solid, glass, stone and ceramics, which crack
        rather than flow, or a material without a published value).
    """

    name: str
    density: float
    young: float
    poisson: float
    damping: Damping | None = None
    source: str = ""
    transverse_shear: float | None = None
    yield_stress: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ParameterError(f"material.name={self.name!r} must be a non-empty string")
        n = self.name
        density = _solid_value(
            f"{n}.density", self.density, DENSITY_RANGE, "kg/m^3", "graphene aerogel to osmium"
        )
        young = _solid_value(
            f"{n}.young", self.young, YOUNG_RANGE, "Pa", "the softest elastomers to diamond"
        )
        object.__setattr__(self, "density", density)
        object.__setattr__(self, "young", young)
        object.__setattr__(
            self,
            "poisson",
            checks.in_range(f"{n}.poisson", self.poisson, -1.0, 0.5, "dimensionless"),
        )
        if self.damping is not None and not isinstance(self.damping, (Rayleigh, LossFactor)):
            raise ParameterError(
                f"{n}.damping={self.damping!r} must be a Rayleigh(alpha, beta) or LossFactor(eta) "
                f"(or None for a ball's material)"
            )
        if self.transverse_shear is not None:
            object.__setattr__(
                self,
                "transverse_shear",
                checks.positive(f"{n}.transverse_shear", self.transverse_shear, "Pa"),
            )
        if self.yield_stress is not None:
            object.__setattr__(
                self, "yield_stress", checks.positive(f"{n}.yield_stress", self.yield_stress, "Pa")
            )

    @property
    def effective_modulus(self) -> float:
        """Plane-strain modulus ``E' = E / (1 - nu^2)``, Pa."""
        return self.young / (1.0 - self.poisson**2)

    @property
    def shear_modulus(self) -> float:
        """Isotropic shear modulus ``G = E / (2 (1 + nu))``, Pa."""
        return self.young / (2.0 * (1.0 + self.poisson))

    @property
    def transverse_shear_modulus(self) -> float:
        """Transverse shear modulus ``G_t``, Pa: :attr:`transverse_shear`, or the isotropic
        :attr:`shear_modulus` where that is None."""
        return self.shear_modulus if self.transverse_shear is None else self.transverse_shear


# The built-in table. Every row cites its source (``source=``); the module
# docstring lists the references in full.
_CHP = "Cremer, Heckl & Petersson, Structure-Borne Sound, 3rd ed. (Springer 2005), Table 4.3"
_BHH = "Bies, Hansen & Howard, Engineering Noise Control, 5th ed. (CRC Press 2017), Table C.1"
_HOP = "Hopkins, Sound Insulation (Butterworth-Heinemann 2007), Table A2"
_MEC = "Mechel (ed.), Formulas of Acoustics, 2nd ed. (Springer 2008), Table 3, pp. 529-530"
_VIG = "Vigran, Building Acoustics (Taylor & Francis 2008), Table 3.1"
_ASH = (
    "Ashby, Materials Selection in Mechanical Design, 4th ed. (Butterworth-Heinemann 2011), "
    "Appendix C data tables and the loss coefficient-modulus chart (Fig. 4.9)"
)
_NKT = (
    "Norton & Karczub, Fundamentals of Noise and Vibration Analysis, 2nd ed. (CUP 2003), Table 6.1"
)

_ROWS: list[Material] = [
    # Thesis Table 3.1 (docs/physics.md, "Materials"): the three MDF boards, measured moduli.
    # Damping: Rayleigh fit to the thesis' MDF recordings (docs/physics.md, "Materials").
    Material(
        "mdf-18",
        700.0,
        5.689e9,
        0.4,
        Rayleigh(35.0, 5e-7),
        "thesis Table 3.1 (18 mm board, measured modulus); damping: docs/physics.md, Materials",
    ),
    Material(
        "mdf-12",
        700.0,
        5.058e9,
        0.4,
        Rayleigh(35.0, 5e-7),
        "thesis Table 3.1 (12 mm board, measured modulus); damping: docs/physics.md, Materials",
    ),
    Material(
        "mdf-6",
        700.0,
        3.385e9,
        0.4,
        Rayleigh(35.0, 5e-7),
        "thesis Table 3.1 (6.15 mm board, measured modulus); damping: docs/physics.md, Materials",
    ),
    # Metals.
    Material(
        "steel",
        7800.0,
        216e9,
        0.3,
        LossFactor(1e-4),
        "elastic: thesis Table 3.1 (steel balls: E = 216 GPa, nu = 0.3, rho 7730-7960); "
        f"damping: eta = 1e-4, {_BHH} (mild steel); {_CHP} gives 2e-5 to 3e-4 "
        "for flexural waves; yield stress (the balls' steel, AISI 52100 bearing steel, "
        "hardened and tempered): 2033 MPa, AZoM datasheet 'AISI 52100 Alloy Steel (UNS G52986)'",
        yield_stress=2.03e9,
    ),
    Material(
        "stainless-steel",
        7910.0,
        200e9,
        0.3,
        LossFactor(1e-4),
        f"{_BHH}, row 'Stainless steel 302' (rho, E, nu, eta); yield stress (type 302, "
        "annealed, typical): 275 MPa, ASM Metals Handbook Desk Edition, 2nd ed. (1998), "
        "wrought stainless steels",
        yield_stress=275e6,
    ),
    Material(
        "aluminium",
        2700.0,
        72e9,
        0.34,
        LossFactor(1e-4),
        f"elastic: {_CHP} (aluminium); damping: eta = 1e-4, {_BHH} (aluminium sheet), "
        "the top of the 3e-6 to 1e-4 flexural range of Cremer et al.; yield stress "
        "(6061-T6, the common plate and bar alloy): 276 MPa, ASM Handbook Vol. 2 (1990), "
        "properties of wrought aluminum alloys",
        yield_stress=276e6,
    ),
    Material(
        "brass",
        8500.0,
        95e9,
        0.33,
        LossFactor(1e-3),
        f"elastic: {_CHP} (brass); damping: eta = 1e-3, {_BHH} and {_MEC}, "
        "the top of the 2e-4 to 1e-3 flexural range of Cremer et al.; yield stress "
        "(C26000 cartridge brass, annealed, OS070): 75 MPa, ASM Handbook Vol. 2 (1990)",
        yield_stress=75e6,
    ),
    Material(
        "copper",
        8900.0,
        125e9,
        0.35,
        LossFactor(2e-3),
        f"{_CHP}, row 'Copper, polycrystal' (rho, E, nu, flexural eta = 2e-3); yield "
        "stress (C11000, annealed): 69 MPa, ASM Handbook Vol. 2 (1990)",
        yield_stress=69e6,
    ),
    # Glass and stone.
    Material(
        "glass",
        2480.0,
        70e9,
        0.2,
        LossFactor(1e-3),
        "elastic: thesis Table 3.1 (glass balls: rho 2480, E 70 GPa, nu 0.2); "
        f"damping: eta = 1e-3, {_NKT} and {_MEC}; {_VIG} gives 6e-4 to 2e-3",
    ),
    Material(
        "granite",
        2650.0,
        43e9,
        0.333,
        LossFactor(1.0 / 150.0),
        "elastic: Leet & Ewing, 'Velocity of elastic waves in granite', Physics 2, 160 "
        "(1932), Quincy granite (rho 2650, E 43 GPa, nu 0.333, from in-situ wave "
        "speeds); damping: eta = 1/Q, Q = 150 at 140-4500 Hz, Birch & Bancroft, "
        "'Elasticity and internal friction in a long column of granite', "
        "Bull. Seismol. Soc. Am. 28, 243 (1938)",
    ),
    Material(
        "concrete",
        2300.0,
        24e9,
        0.2,
        LossFactor(5e-3),
        f"{_BHH}, row 'Concrete, normal' (rho 2300, nu 0.2, eta 5e-3; E = 24 GPa is the "
        f"middle of the printed 18-30 GPa); {_HOP} also gives eta = 5e-3 for cast concrete",
    ),
    Material(
        "plasterboard",
        860.0,
        1490.0**2 * 860.0 * (1.0 - 0.3**2),
        0.3,
        LossFactor(0.0141),
        f"{_HOP}, row 'Plasterboard, natural gypsum' (rho 860, c_L 1490 m/s, nu 0.3, "
        "eta 0.0141); E = c_L^2 rho (1 - nu^2)",
    ),
    # Plastics and rubber.
    Material(
        "acrylic",
        1200.0,
        5.6e9,
        0.35,
        LossFactor(0.06),
        f"PMMA; rho, E (dynamic) and eta = 0.06: {_MEC}, row 'Acryl glass'; nu: {_BHH} "
        "(Plexiglass); Bies et al. and Beranek & Ver (1992) print eta = 0.002 for "
        "Plexiglas, far below Mechel's value",
    ),
    Material(
        "polycarbonate",
        1200.0,
        2.3e9,
        0.35,
        LossFactor(3e-3),
        f"{_BHH}, row 'Polycarbonate' (rho, E, nu, eta); yield stress: 64.5 MPa, the "
        f"middle of the 59-70 MPa of {_ASH}",
        yield_stress=64.5e6,
    ),
    Material(
        "abs",
        1050.0,
        2.2e9,
        0.39,
        LossFactor(0.02),
        f"{_ASH}, ABS (acrylonitrile-butadiene-styrene): rho 1010-1210 kg/m^3, E 1.1-2.9 GPa, "
        "nu 0.38-0.42 (middles taken); eta from the loss-coefficient chart, where the "
        "glassy thermoplastics lie at about 1e-2 ... 5e-2 at room temperature",
    ),
    Material(
        "porcelain",
        2400.0,
        70e9,
        0.22,
        LossFactor(1e-3),
        "Kingery, Bowen & Uhlmann, Introduction to Ceramics, 2nd ed. (Wiley 1976), "
        f"Table 15.5 (porcelain: E about 70 GPa); rho and nu: {_ASH}, technical ceramics "
        "and glasses; eta from the same loss-coefficient chart, where glassy ceramics lie "
        "at about 1e-4 ... 1e-3 (the glassy phase of porcelain puts it at the upper end)",
    ),
    Material(
        "rubber",
        1150.0,
        55e6,
        0.49,
        LossFactor(0.05),
        f"{_BHH}, row 'Rubber-neoprene' (nu 0.49, eta 0.05; rho and E are the middles of "
        "the printed 1100-1200 kg/m^3 and 10-100 MPa); nu = 0.49 as printed: the "
        "incompressible limit 0.5 (infinite bulk modulus) is outside the allowed range",
    ),
    # Woods (modulus along the grain).
    Material(
        "oak",
        630.0,
        12e9,
        0.35,
        LossFactor(0.01),
        f"elastic: {_BHH}, row 'Oak' (rho 630, E 12 GPa along the grain, nu 0.35); "
        f"damping: eta = 0.01, {_MEC} (oak wood); Bies et al. print 0.04",
    ),
    Material(
        "hardwood",
        630.0,
        12e9,
        0.35,
        LossFactor(0.01),
        f"the 'oak' row: elastic {_BHH} (Oak), damping {_MEC} (oak wood, eta = 0.01)",
    ),
    Material(
        "pine",
        500.0,
        10.1e9,
        0.4,
        LossFactor(0.01),
        f"rho, E (along the grain): {_BHH}, row 'Scots pine'; nu 0.4: {_VIG} (fir, "
        f"spruce); damping: eta = 0.01, {_MEC} (pine wood); Vigran gives 0.008-0.01",
    ),
    Material(
        "plywood",
        710.0,
        3850.0**2 * 710.0 * (1.0 - 0.3**2),
        0.3,
        LossFactor(0.016),
        f"{_HOP}, row 'Plywood (Birch)' (rho 710, c_L 3850 m/s, nu 0.3, eta 0.016); "
        f"E = c_L^2 rho (1 - nu^2); {_NKT} gives eta = 0.015",
    ),
]

TABLE: dict[str, Material] = {m.name: m for m in _ROWS}


#: Other names of table rows.
ALIASES = {
    "ceramic": "porcelain",
    "pmma": "acrylic",
    "aluminum": "aluminium",
    "stainless": "stainless-steel",
}


def names() -> list[str]:
    """Names of the built-in materials, sorted."""
    return sorted(TABLE)


def get(name: str) -> Material:
    """Return the built-in material called ``name``.

    Raises
    ------
    ParameterError
        For an unknown name; the message suggests the nearest names.
    """
    if not isinstance(name, str):
        raise ParameterError(f"material={name!r} must be a material name (str) or a Material")
    key = name.strip().lower()
    key = ALIASES.get(key, key)
    try:
        return TABLE[key]
    except KeyError:
        hint = checks.did_you_mean(key, TABLE, n=3, cutoff=0.5)
        raise ParameterError(
            f"material={name!r} is not in the table{hint}; known: {', '.join(names())}"
        ) from None


def resolve(value, field_name: str = "material") -> Material:
    """A :class:`Material` given as itself or as a table name."""
    if isinstance(value, Material):
        return value
    if isinstance(value, str):
        try:
            return get(value)
        except ParameterError as exc:
            raise ParameterError(f"{field_name}: {exc}") from None
    raise ParameterError(f"{field_name}={value!r} must be a Material or a material name")


def damping_text(d) -> str:
    if isinstance(d, LossFactor):
        return f"loss factor {d.eta:.3g}"
    return f"Rayleigh alpha {d.alpha:g} 1/s, beta {d.beta:g} s"


def table_markdown() -> str:
    """The built-in table as a Markdown table, one line per row, sorted by name.

    Columns: name, density (kg/m^3), Young's modulus (GPa), Poisson's ratio
    (dimensionless), damping law (loss factor, dimensionless; or Rayleigh
    ``alpha`` in 1/s and ``beta`` in s) and source.

    Returns
    -------
    str
        The table, ending with a newline.
    """
    lines = [
        "| name | density (kg/m^3) | E (GPa) | nu | damping | source |",
        "|---|---|---|---|---|---|",
    ]
    for key in names():
        m = TABLE[key]
        source = m.source.replace("|", "\\|")
        lines.append(
            f"| {m.name} | {m.density:g} | {m.young / 1e9:.4g} | {m.poisson:g} | "
            f"{damping_text(m.damping)} | {source} |"
        )
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------
# Contact surfaces fitted to measurements
# ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ContactSurface:
    """A plate material's side of the ball-plate contact, where an isotropic elastic
    half-space (the thesis' Hertz model) is not what was measured.

    Parameters
    ----------
    transverse_ratio : float in (0, 1]
        ``E_t / E``: the modulus that resists the indentation (for a fibreboard the
        through-thickness modulus, far below the in-plane one that bends the plate) over the
        material's ``young``; dimensionless. The plate's side of the Hertz contact is taken
        isotropic with modulus ``E_t`` and the material's Poisson's ratio.
    dissipation : float >= 0
        Hunt-Crossley loss ``mu`` of ``F = K delta^n (1 + mu delta')``, s/m (Hunt &
        Crossley, J. Appl. Mech. 42 (1975) 440-445): small-loss restitution ``e = 1 - 2/3 mu
        v`` on a rigid support, its loss ``1 - e`` growing like ``v``.
    viscous_time : float >= 0
        The viscoelastic Hertz contact's dissipative time ``A`` of
        ``F = K (delta^(3/2) + (3/2) A delta^(1/2) delta')``, s (Kuwabara & Kono 1987;
        Brilliantov et al. 1996): its loss ``1 - e`` grows like ``v^(1/5)``.
        Exactly one of ``dissipation`` and ``viscous_time`` is nonzero: the surface's one
        loss. With a ball much stiffer than the plate (steel, glass on MDF) the indentation,
        and so the loss, is the plate's.
    source : str
        What the values were fitted on.
    """

    transverse_ratio: float
    dissipation: float = 0.0
    viscous_time: float = 0.0
    source: str = ""

    def __post_init__(self):
        object.__setattr__(
            self,
            "transverse_ratio",
            checks.in_range(
                "transverse_ratio", self.transverse_ratio, 0.0, 1.0, "dimensionless", hi_open=False
            ),
        )
        object.__setattr__(
            self, "dissipation", checks.nonnegative("dissipation", self.dissipation, "s/m")
        )
        object.__setattr__(
            self, "viscous_time", checks.nonnegative("viscous_time", self.viscous_time, "s")
        )
        if (self.dissipation == 0.0) == (self.viscous_time == 0.0):
            raise ParameterError(
                f"dissipation={self.dissipation!r} (s/m) and viscous_time={self.viscous_time!r} "
                f"(s): exactly one of them must be nonzero (the surface's one contact loss, "
                f"Hunt-Crossley or viscoelastic)"
            )


#: MDF's contact surface: two parameters fitted on the thesis' 18 mm board only (docs/physics.md,
#: "Contact losses"): ``E_t / E`` on its five first-impact contact times (Table 3.3, each ball
#: carrying the accelerometer of those measurements, about 1 g; the force pulse's length on
#: both sides, as ``ImpactResult.contact_time``) and the viscoelastic loss's
#: dissipative time ``A`` on the restitution 0.76 of the 10 mm steel ball at 1.4 m/s (section
#: 3.2), both with the finite plate in the contact (synth.physics.modal_contact) at the middle
#: of the board (validation.surface.surface_fit). The 12 and 6 mm boards use them unchanged
#: (``synth bench thesis`` prints fit and prediction errors).
MDF_SURFACE = ContactSurface(
    transverse_ratio=0.1814,
    viscous_time=7.702e-6,
    source=(
        "fitted on the thesis' 18 mm MDF board: E_t / E on its contact times (Table 3.3, ball "
        "with its 1 g accelerometer) and the viscoelastic A on the restitution 0.76 of the "
        "10 mm steel ball at 1.4 m/s (section 3.2), modal plate at the middle"
    ),
)

#: Fitted contact surfaces by material name (:func:`contact_surface`).
SURFACES: dict[str, ContactSurface] = {
    "mdf-18": MDF_SURFACE,
    "mdf-12": MDF_SURFACE,
    "mdf-6": MDF_SURFACE,
}


def contact_surface(material: Material) -> ContactSurface:
    """The fitted :class:`ContactSurface` of a table material (by its name), or
    ``ParameterError`` naming the materials that have one."""
    surface = SURFACES.get(getattr(material, "name", None))
    # a table row, whatever its transverse shear modulus (the contact does not read it)
    if (
        surface is None
        or not isinstance(material, Material)
        or TABLE.get(material.name) != replace(material, transverse_shear=None)
    ):
        raise ParameterError(
            f"plate.material={getattr(material, 'name', material)!r} has no fitted contact "
            f"surface (contact.surface='fitted' needs one of {sorted(SURFACES)}, as in the "
            f"built-in table)"
        )
    return surface


def has_contact_surface(material: Material) -> bool:
    """True if ``material`` has a fitted :class:`ContactSurface` (:func:`contact_surface`)."""
    try:
        contact_surface(material)
    except ParameterError:
        return False
    return True


def with_transverse_shear(material: Material) -> Material:
    """``material`` with the transverse shear modulus its fitted contact surface implies
    (:func:`contact_surface`), for the thick (Mindlin) plate:

        G_t = E_t / (2 (1 + nu)),   E_t = transverse_ratio * E

    The assumption: the board is transversely isotropic, and a plane across its thickness
    is isotropic with the through-thickness modulus ``E_t`` and Poisson's ratio ``nu``
    (docs/physics.md, "Thick plates (Mindlin)"); so ``G_t / G = E_t / E`` and no parameter
    is added to the fitted two. ``ParameterError`` for a material without a fitted surface."""
    surface = contact_surface(material)
    through_thickness = surface.transverse_ratio * material.young
    return replace(material, transverse_shear=through_thickness / (2.0 * (1.0 + material.poisson)))
