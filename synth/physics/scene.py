"""Scene objects: the ball, the plate, the listener and the scene that joins them, frozen
dataclasses validated on construction. A point on a plate is ``(x, y)`` in metres from a
corner (``x`` along its length); a microphone's ``z`` is its height above the plate, m."""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass

from synth import checks
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics.materials import Damping, Material, resolve

BOUNDARIES = ("free", "simply-supported", "clamped")

# Ranges: a ball dropped on a thin plate in a room (thesis ch. 2) with a wide margin, every
# derived figure finite.
#: Ball radius, m: a grain of fine sand (below it the contact is not a continuum's) to 1 m.
MIN_BALL_RADIUS, MAX_BALL_RADIUS = 1e-6, 1.0
#: Ball mass, kg: a steel sphere of MIN_BALL_RADIUS (a lighter ball's force nears float64's
#: underflow) to 1000 kg.
MIN_BALL_MASS, MAX_BALL_MASS = 1e-15, 1000.0
#: Largest plate side or thickness, m.
MAX_PLATE_SIZE = 100.0
#: Thinnest plate, m (aluminium foil is 16 um): a film's bending stiffness ``E h^3`` vanishes.
MIN_PLATE_THICKNESS = 1e-6
#: Drop heights, m: 1 um (4.4 mm/s at impact) to 1 km (140 m/s, still elastic for the table).
MIN_DROP_HEIGHT, MAX_DROP_HEIGHT = 1e-6, 1000.0
#: Farthest microphone coordinate from the plate's corner, m (2.9 s of travel at 343 m/s).
MAX_LISTENER_DISTANCE = 1000.0
#: Largest horizontal speed of a ball at release, m/s (a thrown ball).
MAX_HORIZONTAL_SPEED = 100.0
#: Largest gravity, m/s^2 (the Sun's surface: 274 m/s^2).
MAX_GRAVITY = 1000.0


def check_type(name: str, value, kind: type) -> None:
    """``ParameterError`` naming ``name`` and its value unless ``value`` is a ``kind``."""
    if not isinstance(value, kind):
        raise ParameterError(f"{name}={value!r} must be a {kind.__name__}")


def _closed(name: str, value, lo: float, hi: float, unit: str) -> float:
    """``value`` as a float in ``[lo, hi]``, else ``ParameterError``."""
    return checks.in_range(name, value, lo, hi, unit, lo_open=False, hi_open=False)


def _set(instance, **values) -> None:
    """Set the checked ``values`` on a frozen dataclass ``instance``."""
    for name, value in values.items():
        object.__setattr__(instance, name, value)


def _check_mass(m: float, origin: str, hint: str = "") -> float:
    """A derived ball mass ``m`` (kg) within [MIN_BALL_MASS, MAX_BALL_MASS]."""
    if not MIN_BALL_MASS <= m <= MAX_BALL_MASS:
        raise ParameterError(
            f"ball.mass={m:.4g} kg ({origin}) must be in [{MIN_BALL_MASS:g}, "
            f"{MAX_BALL_MASS:g}] (kg){hint}"
        )
    return m


@dataclass(frozen=True)
class Ball:
    """A homogeneous elastic sphere of ``material`` (a :class:`Material` or a table name),
    ``radius`` in [1e-6, 1] m, ``mass`` in [1e-15, 1000] kg (default ``density 4/3 pi r^3``)."""

    material: Material | str
    radius: float
    mass: float | None = None

    def __post_init__(self):
        material = resolve(self.material, "ball.material")
        r = _closed("ball.radius", self.radius, MIN_BALL_RADIUS, MAX_BALL_RADIUS, "metres")
        if self.mass is None:
            m = _check_mass(
                material.density * 4.0 / 3.0 * math.pi * r**3,
                f"from ball.radius={r!r} m and the density {material.density:g} kg/m^3",
                "; give ball.mass or change the radius",
            )
        else:
            m = _closed("ball.mass", self.mass, MIN_BALL_MASS, MAX_BALL_MASS, "kg")
        _set(self, material=material, radius=r, mass=m)


#: Dry air's specific gas constant, J/(kg K), the temperature a hollow ball's gas is weighed
#: at, K (20 degrees C), and the atmosphere above which its gauge pressure is, Pa (ISO 2533
#: standard atmosphere at sea level).
AIR_GAS_CONSTANT = 287.05
GAS_TEMPERATURE = 293.15
ATMOSPHERE = 101_325.0
#: Largest gauge pressure of a hollow ball's gas, Pa (10 bar: a pressurised ball is below 1).
MAX_GAUGE_PRESSURE = 1e6


@dataclass(frozen=True)
class HollowBall(Ball):
    """A thin spherical shell filled with air (table-tennis ball, tennis ball, basketball), usable
    wherever a :class:`Ball` is; its contact is the thin-shell law (docs/physics.md, "Hollow
    balls"). Keyword fields: wall ``thickness`` in (0, R_s / 2] m; gauge ``pressure`` in [0, 1e6]
    Pa; ``cover_thickness`` in [0, radius / 2) m (a tennis ball's felt: mass and size, no force),
    ``R_s = radius - cover_thickness``; ``cover_mass`` in [0, 1000] kg. The mass is derived: shell,
    air at ``ATMOSPHERE + pressure`` and :data:`GAS_TEMPERATURE` (ideal gas), cover."""

    _: KW_ONLY
    thickness: float | None = None
    pressure: float = 0.0
    cover_thickness: float = 0.0
    cover_mass: float = 0.0

    def __post_init__(self):
        if self.mass is not None:
            raise ParameterError(
                f"ball.mass={self.mass!r}: a hollow ball's mass is derived from its shell "
                f"(ball.thickness, ball.material's density) and its gas (ball.pressure); "
                f"leave ball.mass out"
            )
        if self.thickness is None:
            raise ParameterError("ball.thickness is required for a hollow ball (metres)")
        R = _closed("ball.radius", self.radius, MIN_BALL_RADIUS, MAX_BALL_RADIUS, "metres")
        c = checks.in_range(
            "ball.cover_thickness", self.cover_thickness, 0.0, 0.5 * R,
            "metres (below half the radius)", lo_open=False,
        )  # fmt: skip
        h = checks.in_range(
            "ball.thickness", self.thickness, 0.0, 0.5 * (R - c),
            "metres (at most half the shell's radius, ball.radius - ball.cover_thickness)",
            hi_open=False,
        )  # fmt: skip
        _set(
            self,
            material=resolve(self.material, "ball.material"),
            radius=R,
            thickness=h,
            pressure=_closed("ball.pressure", self.pressure, 0.0, MAX_GAUGE_PRESSURE, "Pa (gauge)"),
            cover_thickness=c,
            cover_mass=_closed("ball.cover_mass", self.cover_mass, 0.0, MAX_BALL_MASS, "kg"),
        )
        m = self.shell_mass + self.gas_mass + self.cover_mass
        _set(self, mass=_check_mass(m, f"from ball.radius={R!r} m, ball.thickness={h!r} m"))

    @property
    def shell_radius(self) -> float:
        """``R_s = R - cover_thickness``, m."""
        return self.radius - self.cover_thickness

    @property
    def inner_radius(self) -> float:
        """``R_s - h``, m."""
        return self.shell_radius - self.thickness

    @property
    def shell_mass(self) -> float:
        """Mass of the shell, kg."""
        outer, inner = self.shell_radius, self.inner_radius
        return self.material.density * 4.0 / 3.0 * math.pi * (outer**3 - inner**3)

    @property
    def gas_mass(self) -> float:
        """Mass of the air inside at ``ATMOSPHERE + pressure``, kg."""
        density = (ATMOSPHERE + self.pressure) / (AIR_GAS_CONSTANT * GAS_TEMPERATURE)
        return density * 4.0 / 3.0 * math.pi * self.inner_radius**3


@dataclass(frozen=True)
class Plate:
    """A rectangular plate of ``material`` (a :class:`Material` or a table name), ``thickness``
    in [1e-6, 100] m (at most the smaller side), ``length`` along x and ``width`` along y in (0,
    100] m, and the ``boundary`` of all four edges (:data:`BOUNDARIES`)."""

    material: Material | str
    thickness: float
    length: float
    width: float
    boundary: str = "free"

    def __post_init__(self):
        _set(self, material=resolve(self.material, "plate.material"))
        for k in ("length", "width"):
            v = checks.positive_at_most(f"plate.{k}", getattr(self, k), MAX_PLATE_SIZE, "metres")
            _set(self, **{k: v})
        h, lo = self.thickness, MIN_PLATE_THICKNESS
        _set(self, thickness=_closed("plate.thickness", h, lo, MAX_PLATE_SIZE, "metres"))
        checks.choice("plate.boundary", self.boundary, BOUNDARIES)
        if self.thickness > min(self.length, self.width):
            raise ParameterError(
                f"plate.thickness={self.thickness!r} must not exceed the plate's smaller side "
                f"{min(self.length, self.width)!r} (metres): a thin-plate model needs h << a, b"
            )

    def damping_law(self) -> Damping:
        """The material's damping law (the modes' decay rates need it), else ``ParameterError``."""
        if self.material.damping is None:
            raise ParameterError(
                f"plate.material.damping=None ({self.material.name!r}): computing the plate's "
                f"modes needs a damping law, Rayleigh(alpha, beta) or LossFactor(eta), for "
                f"their decay (a contact computation alone needs none)"
            )
        return self.material.damping

    @property
    def flexural_rigidity(self) -> float:
        """Bending stiffness ``D = E h^3 / (12 (1 - nu^2))``, N m."""
        m = self.material
        return m.young * self.thickness**3 / (12.0 * (1.0 - m.poisson**2))

    @property
    def surface_density(self) -> float:
        """Mass per unit area ``rho h``, kg/m^2."""
        return self.material.density * self.thickness

    @property
    def mass(self) -> float:
        """Total mass ``rho h a b``, kg."""
        return self.surface_density * self.length * self.width

    def check_position(self, position, name: str = "position") -> tuple[float, float]:
        """The point ``(x, y)`` (m from a corner), checked to be on the plate."""
        x, y = checks.point(name, position, 2)
        if not (0.0 <= x <= self.length and 0.0 <= y <= self.width):
            raise ParameterError(
                f"{name}=({x!r}, {y!r}) is off the plate: x must be in [0, {self.length!r}] "
                f"and y in [0, {self.width!r}] (metres from a corner)"
            )
        return (x, y)

    @property
    def centre(self) -> tuple[float, float]:
        """The middle of the plate, ``(length/2, width/2)``, metres."""
        return (0.5 * self.length, 0.5 * self.width)


@dataclass(frozen=True)
class Accelerometer:
    """A pickup of the plate's normal acceleration (m/s^2) at ``position`` ``(x, y)``, m."""

    position: tuple[float, float]

    def __post_init__(self):
        _set(self, position=checks.point("listener.position", self.position, 2))


@dataclass(frozen=True)
class Microphone:
    """A pressure microphone (Pa) above the (baffled) plate at ``position`` ``(x, y, z)``, m: x, y
    within 1000 of a plate corner, z in (0, 1000]."""

    position: tuple[float, float, float]

    def __post_init__(self):
        pos = checks.point("listener.position", self.position, 3)
        if not pos[2] > 0.0:
            raise ParameterError(
                f"listener.position.z={pos[2]!r} must be > 0 (metres above the plate)"
            )
        for axis, value in zip("xyz", pos):
            if abs(value) > MAX_LISTENER_DISTANCE:
                raise ParameterError(
                    f"listener.position.{axis}={value!r} must be within "
                    f"{MAX_LISTENER_DISTANCE:g} of the plate's corner (metres)"
                )
        _set(self, position=pos)


Listener = Accelerometer | Microphone

CONTACT_LAWS = (
    "hertz", "elastic-foundation", "hunt-crossley", "viscoelastic", "power-law", "shell"
)  # fmt: skip
#: The contact laws' parameters (fields of :class:`Contact`).
LAW_OPTIONS = ("dissipation", "viscous_time", "exponent", "stiffness", "layer_depth")
#: The two surfaces in the contact (:class:`Contact`'s ``surface``).
SURFACE_MODELS = ("ideal", "material", "fitted", "auto")
#: The plate in the contact (:class:`Contact`'s ``plate``; :mod:`synth.physics.plate_choice`).
PLATE_MODELS = ("impedance", "modal", "auto")
#: The contact model of a :class:`Contact` that names none: the one closest to measurement.
DEFAULT_CONTACT_MODEL = "measured"
#: The modal plate's theory of a :class:`Contact` that names none.
DEFAULT_PLATE_THEORY = "kirchhoff"
#: The laws' parameters > 0 and their units (``exponent`` is in (1, 4]).
_POSITIVE_OPTIONS = {"dissipation": "s/m", "viscous_time": "s", "stiffness": "N/m^n",
                     "layer_depth": "metres"}  # fmt: skip
#: The parameters each law needs, and what they are (the others need none).
LAW_NEEDS = {
    "hunt-crossley": (("dissipation",), "mu, s/m, > 0"),
    "viscoelastic": (("viscous_time",), "A, s, > 0"),
    "power-law": (("exponent", "stiffness"), "n and K_n, N/m^n"),
}


def check_law_options(law: str, given: dict, prefix: str = "") -> None:
    """``ParameterError`` for a parameter of ``given`` (None: not given) that the contact
    ``law`` does not take, or one it needs and lacks; ``prefix``: the section in the names."""
    needs, what = LAW_NEEDS.get(law, ((), ""))
    allowed = needs + (("layer_depth",) if law == "elastic-foundation" else ())
    law_name = f"{prefix}law" if prefix else "contact"
    for key, value in given.items():
        if value is not None and key not in allowed:
            raise ParameterError(f"{prefix}{key}={value!r} does not apply to {law_name}={law!r}")
    missing = [prefix + key for key in needs if given.get(key) is None]
    if missing:
        raise ParameterError(f"{law_name}={law!r} needs {' and '.join(missing)} ({what})")


#: Named contact models, (law, plate, surface): "measured" the closest to measurement,
#: "thesis" the thesis' model (lossless Hertz, impedance plate), "fitted" the fitted surface
#: with the modes in every contact.
CONTACT_MODELS = {
    "measured": ("hertz", "auto", "auto"),
    "thesis": ("hertz", "impedance", "ideal"),
    "fitted": ("hertz", "modal", "fitted"),
}


@dataclass(frozen=True)
class Contact:
    """The contact model and its accuracy (docs/physics.md, "Hertz contact").

    ``law`` (:data:`CONTACT_LAWS`) with its parameters, others refused: ``dissipation`` > 0 s/m
    ("hunt-crossley"), ``viscous_time`` > 0 s ("viscoelastic"), ``exponent`` in (1, 4] and
    ``stiffness`` > 0 N/m^n ("power-law"), ``layer_depth`` > 0 m ("elastic-foundation", default
    the plate's thickness). ``rtol`` in [1e-12, 0.1]: each impact's relative accuracy.
    ``plate``: "impedance", "modal" or "auto". ``surface``: "ideal" (lossless half-spaces),
    "material" (Hertz only: published loss factors), "fitted" (Hertz only) or "auto". ``model``:
    a named law, plate and surface (:data:`CONTACT_MODELS`, default "measured"), those given
    taking precedence. ``theory``: the modal plate's, "kirchhoff" (default) or "mindlin"."""

    law: str | None = None
    dissipation: float | None = None
    exponent: float | None = None
    stiffness: float | None = None
    layer_depth: float | None = None
    rtol: float = 1e-9
    plate: str | None = None
    surface: str | None = None
    model: str | None = None
    theory: str | None = None
    viscous_time: float | None = None

    def __post_init__(self):
        self._resolve_model()
        theory = DEFAULT_PLATE_THEORY if self.theory is None else self.theory
        checks.choice("contact.theory", theory, ("kirchhoff", "mindlin"))
        if theory != "kirchhoff" and self.plate == "impedance":
            raise ParameterError(
                f"contact.theory={theory!r} applies to contact.plate='modal' or 'auto' only, not "
                f"{self.plate!r}"
            )
        _set(self, theory=theory)
        checks.choice("contact.law", self.law, CONTACT_LAWS)
        checks.choice("contact.plate", self.plate, PLATE_MODELS)
        checks.choice("contact.surface", self.surface, SURFACE_MODELS)
        if self.surface in ("fitted", "material") and self.law != "hertz":
            raise ParameterError(
                f"contact.surface={self.surface!r} applies to contact.law='hertz' only, not "
                f"{self.law!r}"
            )
        _set(self, rtol=_closed("contact.rtol", self.rtol, 1e-12, 0.1, "dimensionless"))
        for name, unit in _POSITIVE_OPTIONS.items():
            if getattr(self, name) is not None:
                _set(self, **{name: checks.positive(f"contact.{name}", getattr(self, name), unit)})
        if self.exponent is not None:
            n = checks.in_range("contact.exponent", self.exponent, 1.0, 4.0, "dimensionless",
                                hi_open=False)  # fmt: skip
            _set(self, exponent=n)
        check_law_options(self.law, {k: getattr(self, k) for k in LAW_OPTIONS}, "contact.")

    def _resolve_model(self):
        """``law``, ``plate`` and ``surface`` not given: the ``model``'s."""
        model = DEFAULT_CONTACT_MODEL if self.model is None else self.model
        checks.choice("contact.model", model, CONTACT_MODELS)
        for key, value in zip(("law", "plate", "surface"), CONTACT_MODELS[model], strict=True):
            if getattr(self, key) is None:
                _set(self, **{key: value})

    def options(self) -> dict:
        """The law's parameters as ``contact_parameters`` takes them."""
        options = {k: getattr(self, k) for k in LAW_OPTIONS if getattr(self, k) is not None}
        if self.surface != "ideal":
            options["surface"] = self.surface
        return options


@dataclass(frozen=True)
class Rolling:
    """How a ball dropped with a horizontal velocity rolls (docs/rolling.md, "The ball's path").
    No value is built in (no published rolling-resistance coefficient to cite): a preset states
    them. ``resistance`` ``C_rr`` in [0, 1] (Cross, Am. J. Phys. 84, 221 (2016)); ``spacing`` in
    (0, 0.01] m of the profile's samples; ``rms_height`` >= 0 m of the Matern roughness (0:
    smooth; at most :data:`synth.physics.surface.MAX_ROUGHNESS_SCALE` and the plate's
    thickness) with ``correlation_length`` in (0, 100] m and ``hurst`` in (0, 1] (required when
    rough); ``seed`` >= 0."""

    resistance: float
    spacing: float
    rms_height: float = 0.0
    correlation_length: float | None = None
    hurst: float | None = None
    seed: int = 0

    def __post_init__(self):
        _set(
            self,
            resistance=_closed("rolling.resistance", self.resistance, 0.0, 1.0, "dimensionless"),
            spacing=checks.positive_at_most("rolling.spacing", self.spacing, 1e-2, "metres"),
            rms_height=checks.nonnegative("rolling.rms_height", self.rms_height, "metres"),
        )
        for name in ("correlation_length", "hurst"):
            if self.rms_height > 0.0 and getattr(self, name) is None:
                raise ParameterError(
                    f"rolling.{name} is required with rolling.rms_height={self.rms_height!r} > 0"
                )
        try:
            self.spectrum()
        except ParameterError as exc:
            raise ParameterError(f"rolling.{exc}") from None
        checks.integer_at_least("rolling.seed", self.seed, 0)

    def spectrum(self):
        """The :class:`synth.physics.surface.RoughnessSpectrum`, or None for a smooth plate."""
        from synth.physics.surface import RoughnessSpectrum

        if self.rms_height == 0.0:
            return None
        return RoughnessSpectrum(self.rms_height, self.correlation_length, self.hurst)


@dataclass(frozen=True)
class Scene:
    """A ball dropped on a plate, heard by a listener. Keyword fields: ``drop_height`` in [1e-6,
    1000] m of the ball's lowest point; ``position`` on the plate, m (default the centre);
    ``listener`` (default a microphone 0.2 m above the impact); ``gravity`` in (0, 1000] m/s^2;
    ``contact``; ``velocity`` ``(v_x, v_y)`` at release, m/s (the ball then bounces along a path
    and rolls, and needs ``rolling``)."""

    ball: Ball
    plate: Plate
    _: KW_ONLY
    drop_height: float
    position: tuple[float, float] | None = None
    listener: Listener | None = None
    gravity: float = GRAVITY
    contact: Contact | None = None
    velocity: tuple[float, float] | None = None
    rolling: Rolling | None = None

    def __post_init__(self):
        check_type("ball", self.ball, Ball)
        check_type("plate", self.plate, Plate)
        h = checks.positive_at_most("drop.height", self.drop_height, MAX_DROP_HEIGHT, "metres")
        if h < MIN_DROP_HEIGHT:
            raise ParameterError(
                f"drop.height={self.drop_height!r} must be >= "
                f"{MIN_DROP_HEIGHT:g} and <= {MAX_DROP_HEIGHT:g} (metres)"
            )
        pos = self.plate.centre if self.position is None else self.position
        _set(
            self,
            drop_height=h,
            gravity=checks.positive_at_most("gravity", self.gravity, MAX_GRAVITY, "m/s^2"),
            position=self.plate.check_position(pos, "drop.position"),
        )
        if 2.0 * self.ball.radius > min(self.plate.length, self.plate.width):
            raise ParameterError(
                f"ball.radius={self.ball.radius!r} is too large for the plate: the ball's "
                f"diameter must not exceed the plate's smaller side "
                f"{min(self.plate.length, self.plate.width)!r} (metres)"
            )
        hollow = isinstance(self.ball, HollowBall)
        if self.contact is None:
            _set(self, contact=Contact(law="shell") if hollow else Contact())
        elif not isinstance(self.contact, Contact):
            raise ParameterError(f"contact={self.contact!r} must be a Contact")
        self._check_shell(hollow)
        if self.listener is None:
            _set(self, listener=Microphone((*self.position, 0.2)))
        elif isinstance(self.listener, Accelerometer):
            self.plate.check_position(self.listener.position, "listener.position")
        elif not isinstance(self.listener, Microphone):
            raise ParameterError(
                f"listener={self.listener!r} must be an Accelerometer or a Microphone"
            )
        self._check_path()

    def _check_shell(self, hollow: bool):
        """A hollow ball takes the thin-shell law and the impedance plate (the modal and rolling
        contacts take power laws only); the shell law takes a hollow ball."""
        law, plate = self.contact.law, self.contact.plate
        if hollow and law != "shell":
            raise ParameterError(
                f"contact.law={law!r}: a hollow ball's contact is the thin-shell law, "
                f"contact.law='shell'"
            )
        if not hollow and law == "shell":
            raise ParameterError(
                "contact.law='shell' applies to a hollow ball only (ball.thickness given)"
            )
        if hollow and plate == "modal":
            raise ParameterError(
                "contact.plate='modal' does not take contact.law='shell' (the modal contact "
                "integrates the power laws); allowed: 'impedance', 'auto' (the impedance plate)"
            )
        if hollow and self.velocity is not None:
            raise ParameterError(
                f"drop.velocity={self.velocity!r}: a hollow ball does not roll in this engine "
                f"(the rolling contact takes the power laws); leave drop.velocity out"
            )

    def _check_path(self):
        """A horizontal velocity needs ``rolling`` and a plate that follows a moving point."""
        if self.rolling is not None and not isinstance(self.rolling, Rolling):
            raise ParameterError(f"rolling={self.rolling!r} must be a Rolling")
        if self.rolling is not None and self.rolling.rms_height > self.plate.thickness:
            raise ParameterError(
                f"rolling.rms_height={self.rolling.rms_height!r} must be <= plate.thickness="
                f"{self.plate.thickness!r} (metres): a roughness is a variation of the "
                f"plate's surface, not taller than the plate"
            )
        if self.velocity is None:
            return
        vx, vy = checks.point("drop.velocity", self.velocity, 2, "m/s")
        if math.hypot(vx, vy) > MAX_HORIZONTAL_SPEED:
            raise ParameterError(
                f"drop.velocity={self.velocity!r}: its magnitude must be at most "
                f"{MAX_HORIZONTAL_SPEED:g} m/s"
            )
        _set(self, velocity=(vx, vy))
        if self.rolling is None:
            raise ParameterError(
                f"drop.velocity={self.velocity!r} needs the [rolling] section: the ball rolls "
                f"at the end of its bounces (rolling.resistance, rolling.spacing, roughness)"
            )
        if self.contact.plate == "modal":
            raise ParameterError(
                "contact.plate='modal' with drop.velocity: the modal plate's contact follows "
                "one point; a ball moving along a path takes the plate's impedance "
                "(contact.plate='impedance' or 'auto')"
            )

    @property
    def moving(self) -> bool:
        """True if the ball is released with a horizontal velocity."""
        return self.velocity is not None and self.velocity != (0.0, 0.0)
