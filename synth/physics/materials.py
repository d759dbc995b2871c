"""Materials: elastic constants, density and damping (docs/physics.md, "Materials").
:data:`TABLE` is read from ``materials.toml``, every row citing its source (docs/materials.md)."""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from synth import checks
from synth.errors import ParameterError

#: Young's modulus a material may have, Pa: from bottlebrush elastomers, ~100 Pa (Daniel et
#: al., Nature Materials 15, 183 (2016)), to diamond, 1.21 TPa (Klein & Cardinale, Diamond
#: Relat. Mater. 2, 918 (1993)); outside it a value is a unit error, not a solid.
YOUNG_RANGE = (100.0, 1.21e12)

#: Density a material may have, kg/m^3 (closed interval): from graphene aerogels, 0.16 (Sun,
#: Xu & Gao, Advanced Materials 25, 2554 (2013)), to osmium, 22 590 (CRC Handbook of
#: Chemistry and Physics, "Density of the elements").
DENSITY_RANGE = (0.16, 22_590.0)
#: The closed ranges of a material's constants, their units and what bounds them.
_RANGES = {"density": (DENSITY_RANGE, "kg/m^3: graphene aerogel to osmium"),
           "young": (YOUNG_RANGE, "Pa: the softest elastomers to diamond")}  # fmt: skip


@dataclass(frozen=True)
class Rayleigh:
    """Rayleigh ``sigma = (alpha + beta omega^2) / 2``, ``alpha``, ``beta`` >= 0 (1/s, s)."""

    alpha: float
    beta: float

    def __post_init__(self):
        object.__setattr__(self, "alpha", checks.nonnegative("damping.alpha", self.alpha, "1/s"))
        object.__setattr__(self, "beta", checks.nonnegative("damping.beta", self.beta, "s"))

    def decay_rate(self, omega) -> np.ndarray:
        """Amplitude decay rate (1/s) at ``omega`` (rad/s)."""
        omega = np.asarray(omega, dtype=float)
        return 0.5 * self.alpha + 0.5 * self.beta * omega * omega


@dataclass(frozen=True)
class LossFactor:
    """Constant loss factor ``eta`` in [0, 1) (dimensionless): ``sigma = eta omega / 2``."""

    eta: float

    def __post_init__(self):
        eta = checks.in_range("damping.eta", self.eta, 0.0, 1.0, "dimensionless", lo_open=False)
        object.__setattr__(self, "eta", eta)

    def decay_rate(self, omega) -> np.ndarray:
        """Amplitude decay rate (1/s) at ``omega`` (rad/s)."""
        return 0.5 * self.eta * np.asarray(omega, dtype=float)


Damping = Rayleigh | LossFactor


@dataclass(frozen=True)
class Material:
    """An elastic material: ``name``; ``density`` (kg/m^3, :data:`DENSITY_RANGE`); ``young``
    (Pa, :data:`YOUNG_RANGE`); ``poisson`` in (-1, 0.5); ``damping`` of the bending modes;
    ``source``; ``transverse_shear`` ``G_t`` > 0 Pa for the Mindlin plate (None: isotropic);
    ``yield_stress`` ``Y`` > 0 Pa of a ductile material (docs/physics.md, "Yield of the
    contact"; None: brittle or unpublished)."""

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
        checked = {
            key: checks.in_range(f"{n}.{key}", getattr(self, key), *bounds, why, hi_open=False,
                                 lo_open=False)
            for key, (bounds, why) in _RANGES.items()
        }  # fmt: skip
        checked["poisson"] = checks.in_range(
            f"{n}.poisson", self.poisson, -1.0, 0.5, "dimensionless"
        )
        for field in ("transverse_shear", "yield_stress"):
            if getattr(self, field) is not None:
                checked[field] = checks.positive(f"{n}.{field}", getattr(self, field), "Pa")
        for field, value in checked.items():
            object.__setattr__(self, field, value)
        if self.damping is not None and not isinstance(self.damping, (Rayleigh, LossFactor)):
            raise ParameterError(
                f"{n}.damping={self.damping!r} must be a Rayleigh(alpha, beta) or LossFactor(eta) "
                f"(or None for a ball's material)"
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
        """``G_t``, Pa: :attr:`transverse_shear`, else :attr:`shear_modulus`."""
        return self.shear_modulus if self.transverse_shear is None else self.transverse_shear


def _row(name: str, row: dict) -> Material:
    """A row of ``materials.toml``: ``E = c_L^2 rho (1 - nu^2)`` where it gives the plate speed
    ``c_L`` (m/s, Hopkins 2007, Table A2) instead of ``E``."""
    rho, nu = row["density"], row["poisson"]
    young = row["plate_speed"] ** 2 * rho * (1.0 - nu**2) if "plate_speed" in row else row["young"]
    damping = Rayleigh(*row["rayleigh"]) if "rayleigh" in row else LossFactor(row["eta"])
    return Material(
        name, rho, young, nu, damping, row["source"], yield_stress=row.get("yield_stress")
    )


with open(Path(__file__).with_name("materials.toml"), "rb") as _file:
    TABLE: dict[str, Material] = {k: _row(k, row) for k, row in tomllib.load(_file).items()}

#: Other names of table rows.
ALIASES = {"ceramic": "porcelain", "pmma": "acrylic", "aluminum": "aluminium",
           "stainless": "stainless-steel"}  # fmt: skip


def names() -> list[str]:
    """Names of the built-in materials, sorted."""
    return sorted(TABLE)


def get(name: str) -> Material:
    """The built-in material ``name`` (any case, or an alias), else ``ParameterError``."""
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


@dataclass(frozen=True)
class ContactSurface:
    """A plate material's measured side of the contact: ``transverse_ratio`` ``E_t / E`` in (0,
    1], the modulus resisting indentation; and exactly one loss: ``dissipation`` ``mu`` >= 0
    s/m (Hunt & Crossley, J. Appl. Mech. 42 (1975) 440-445) or ``viscous_time`` ``A`` >= 0 s
    (Kuwabara & Kono 1987; Brilliantov et al. 1996); ``source``, what it was fitted on."""

    transverse_ratio: float
    dissipation: float = 0.0
    viscous_time: float = 0.0
    source: str = ""

    def __post_init__(self):
        ratio = checks.in_range("transverse_ratio", self.transverse_ratio, 0.0, 1.0,
                                "dimensionless", hi_open=False)  # fmt: skip
        object.__setattr__(self, "transverse_ratio", ratio)
        for name, unit in (("dissipation", "s/m"), ("viscous_time", "s")):
            object.__setattr__(self, name, checks.nonnegative(name, getattr(self, name), unit))
        if (self.dissipation == 0.0) == (self.viscous_time == 0.0):
            raise ParameterError(
                f"dissipation={self.dissipation!r} (s/m) and viscous_time={self.viscous_time!r} "
                f"(s): exactly one of them must be nonzero (the surface's one contact loss, "
                f"Hunt-Crossley or viscoelastic)"
            )


#: MDF's contact surface, fitted on the thesis' 18 mm board only (docs/physics.md, "Contact
#: losses"): ``E_t / E`` on its five first-impact contact times (Table 3.3) and ``A`` on the
#: restitution 0.76 of the 10 mm steel ball at 1.4 m/s (section 3.2). The 12 and 6 mm boards
#: use it unchanged (``synth bench thesis`` prints fit and prediction errors).
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
SURFACES: dict[str, ContactSurface] = dict.fromkeys(("mdf-18", "mdf-12", "mdf-6"), MDF_SURFACE)


def contact_surface(material: Material) -> ContactSurface:
    """The fitted :class:`ContactSurface` of a table material, else ``ParameterError``."""
    if not has_contact_surface(material):
        raise ParameterError(
            f"plate.material={getattr(material, 'name', material)!r} has no fitted contact "
            f"surface (contact.surface='fitted' needs one of {sorted(SURFACES)}, as in the "
            f"built-in table)"
        )
    return SURFACES[material.name]


def has_contact_surface(material: Material) -> bool:
    """True if ``material`` has a fitted :class:`ContactSurface`."""
    named = isinstance(material, Material) and material.name in SURFACES
    return named and TABLE.get(material.name) == replace(material, transverse_shear=None)


def with_transverse_shear(material: Material) -> Material:
    """``material`` with ``G_t`` (Pa) of its fitted surface, for the Mindlin plate."""
    surface = contact_surface(material)
    through_thickness = surface.transverse_ratio * material.young
    return replace(material, transverse_shear=through_thickness / (2.0 * (1.0 + material.poisson)))
