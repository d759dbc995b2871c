"""The hollow balls against their rule books' bounce tests (``synth bench hollow``).

Each sports ball of the presets (table tennis, tennis, basketball; docs/physics.md, "Hollow
balls") is dropped from its rule book's height onto the rule book's surface and its rebound
height (from the engine's rebound speed) is set beside the height the rule book requires.
The rule books measure heights in air, so the fall and the rise are flights with the air's
quadratic drag, ``F = rho C_D pi R^2 v^2 / 2``, each ball's drag coefficient a published one
(:func:`fall_speed`, :func:`rise_height`); the height without drag is printed beside it.
Nothing here is tuned to the rule books: the balls' parameters are their presets'
(dimensions and masses from the rule books, the shells' materials from the table with their
published loss factors), and a miss is reported as one.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from benchmarks.common import markdown_table
from synth.constants import AIR_DENSITY, GRAVITY
from synth.physics.contact import solve_impact
from synth.physics.scene import Plate


@dataclass(frozen=True)
class RuleBookTest:
    """One rule book's bounce test: the ball's preset, the surface (``surface`` a
    :class:`Plate`; ``surface_name`` its description), the drop height (m, from the bottom
    of the ball) and the required rebound range (m, to the bottom of the ball, or to its top
    with ``to_top``), the rule's source and a note; and, where one has been read, a published
    contact time of the ball (``contact_time``, s) with its source (``contact_source``); the
    ball's drag coefficient in still air (``drag_coefficient``, dimensionless, at the test's
    Reynolds number) with its source (``drag_source``); where one has been read, the published
    range of the shell material's loss factor (``loss_range``, dimensionless) with its source
    (``loss_source``)."""

    ball: str
    preset: str
    surface_name: str
    surface: Plate
    source: str
    drop: float
    rebound_low: float
    rebound_high: float
    drag_coefficient: float
    drag_source: str
    note: str = ""
    to_top: bool = False
    contact_time: float | None = None
    contact_source: str = ""
    loss_range: tuple[float, float] | None = None
    loss_source: str = ""


#: The rule books' tests. The ITTF's "standard steel block" is a 0.1 m steel plate here (its
#: impedance takes about 1e-5 of the ball's energy: a massive block for a 2.7 g ball); the
#: ITF's concrete base and FIBA's playing surface are the presets' own.
RULE_BOOK_TESTS = (
    RuleBookTest(
        "table tennis (40 mm, ABS shell)",
        "table-tennis-ball-on-table",
        "steel block (0.1 m steel)",
        Plate("steel", 0.1, 0.3, 0.3),
        "ITTF Technical Leaflet T3 (The Ball): dropped 305 mm onto a standard steel block",
        0.305,
        0.240,
        0.260,
        0.445,
        "R. M. French, 'My favorite experiment, part 4: dropping a ping-pong ball', "
        "Experimental Techniques (Society for Experimental Mechanics): about 0.445 for the "
        "40 mm ball from the published values",
        loss_range=(0.0138, 0.0446),
        loss_source="Granta Design, MaterialUniverse, ABS (extrusion): mechanical loss "
        "coefficient (tan delta)",
    ),
    RuleBookTest(
        "tennis (pressurised, 80 kPa)",
        "tennis-ball-on-concrete",
        "concrete (0.15 m slab)",
        Plate("concrete", 0.15, 4.0, 4.0),
        "ITF Rules of Tennis, Appendix I: dropped 254 cm onto a concrete base",
        2.54,
        1.35,
        1.47,
        0.507,
        "R. Cross & C. Lindsey, 'Measurements of drag and lift on tennis balls in flight', "
        "Sports Engineering 17 (2014) 89: new balls in free flight, 0.507 +- 0.024, "
        "independent of their speed and spin",
        "the published contact time is a court's in play ('the five milliseconds that the two "
        "are in contact'), at play's speeds, not the drop test's. Its wall 'collapses "
        "inwards, resulting in a sudden decrease in ball stiffness' once the force has risen "
        "to about half its peak (R. Cross, 'Dynamic properties of tennis balls', Sports "
        "Engineering 2 (1999) 23, abstract); the shell law has the wall's inversion "
        "(Pogorelov) but not the cloth cover, whose compression and loss are left out (its "
        "mass and thickness are in the ball)",
        contact_time=5e-3,
        contact_source="H. Brody, answer to 'Is it possible for a tennis ball that is heavy "
        "with topspin ... to increase its forward velocity after it hits the ground?' "
        "(Scientific American, Ask the Experts)",
    ),
    RuleBookTest(
        "basketball (size 7, 0.55 bar)",
        "basketball-on-wooden-floor",
        "oak floor (22 mm)",
        Plate("oak", 0.022, 2.4, 0.6, boundary="simply-supported"),
        "FIBA Official Basketball Rules, Basketball Equipment: dropped 1.8 m onto the "
        "playing surface",
        1.8,
        1.2,
        1.4,
        0.47,
        "the value commonly given for a smooth sphere below the drag crisis (the basketball's "
        "Reynolds number is about 1e5); no basketball's own measured value has been read",
        "FIBA measures the drop from the bottom of the ball and the rebound to its top: the "
        "engine's rebound here is its bottom's height plus the ball's diameter",
        to_top=True,
    ),
)


def terminal_speed(mass: float, radius: float, drag_coefficient: float) -> float:
    """The terminal speed (m/s) of a ball of ``mass`` (kg) and ``radius`` (m) falling in still
    air of :data:`~synth.constants.AIR_DENSITY` with quadratic drag:
    ``v_t = sqrt(2 m g / (rho C_D pi R^2))``."""
    area = math.pi * radius * radius
    return math.sqrt(2.0 * mass * GRAVITY / (AIR_DENSITY * drag_coefficient * area))


def fall_speed(height: float, v_t: float) -> float:
    """The speed (m/s) of a ball released from rest after falling ``height`` (m) with
    quadratic drag (terminal speed ``v_t``, m/s): ``v^2 = v_t^2 (1 - exp(-2 g h / v_t^2))``
    (``m dv/dt = m g - m g v^2 / v_t^2`` integrated over the height)."""
    return v_t * math.sqrt(-math.expm1(-2.0 * GRAVITY * height / (v_t * v_t)))


def rise_height(speed: float, v_t: float) -> float:
    """The height (m) a ball thrown up at ``speed`` (m/s) reaches with quadratic drag
    (terminal speed ``v_t``, m/s): ``h = v_t^2 / (2 g) ln(1 + v^2 / v_t^2)``."""
    return v_t * v_t / (2.0 * GRAVITY) * math.log1p((speed / v_t) ** 2)


@dataclass(frozen=True)
class HollowRow:
    """A rule-book test's outcome: the engine's rebound height (m, measured as the rule book
    measures it, through the air's drag; ``rebound_in_vacuum`` without it), restitution,
    contact time (s, the force pulse's length) and peak deflection (m), and its error: the
    relative distance of the rebound from the required range (0 inside it)."""

    test: RuleBookTest
    rebound: float
    rebound_in_vacuum: float
    restitution: float
    contact_time: float
    deflection: float

    @property
    def contact_time_error(self) -> float | None:
        """The engine's contact time relative to the published one, minus 1 (dimensionless;
        None where no published contact time has been read)."""
        if self.test.contact_time is None:
            return None
        return self.contact_time / self.test.contact_time - 1.0

    @property
    def error(self) -> float:
        """Relative distance of the engine's rebound from the nearest end of the range
        (dimensionless; positive above, negative below, 0 inside)."""
        t = self.test
        if self.rebound > t.rebound_high:
            return self.rebound / t.rebound_high - 1.0
        if self.rebound < t.rebound_low:
            return self.rebound / t.rebound_low - 1.0
        return 0.0


def rule_book_row(test: RuleBookTest, rtol: float = 1e-9) -> HollowRow:
    """The engine's outcome of ``test``: the preset's ball dropped through still air on the
    test's surface (the infinite plate's impedance: the middle of the surface) at standard
    gravity, and its rise through the air after the impact."""
    from synth.io.presets import load_preset

    return _drop_through_air(test, load_preset(test.preset).ball, rtol)


def _drop_through_air(test: RuleBookTest, ball, rtol: float) -> HollowRow:
    v_t = terminal_speed(ball.mass, ball.radius, test.drag_coefficient)
    speed = fall_speed(test.drop, v_t)
    r = solve_impact(ball, test.surface, speed, contact="shell", rtol=rtol)
    speed_in_vacuum = math.sqrt(2.0 * GRAVITY * test.drop)
    vacuum = solve_impact(ball, test.surface, speed_in_vacuum, contact="shell", rtol=rtol)
    top = 2.0 * ball.radius if test.to_top else 0.0
    return HollowRow(
        test,
        rise_height(r.rebound_speed, v_t) + top,
        vacuum.rebound_speed**2 / (2.0 * GRAVITY) + top,
        r.restitution,
        r.contact_time,
        r.max_penetration,
    )


def rebounds_over_loss_range(test: RuleBookTest, rtol: float = 1e-9) -> tuple[float, float]:
    """The rebounds (m, through the air) of ``test``'s ball with its shell material's loss
    factor at the ends of its published ``loss_range``, the rest of the ball its preset's:
    how far the loss factor's published spread moves the rebound (not a fit)."""
    low, high = (rebound_with_shell_loss(test, eta, rtol) for eta in test.loss_range)
    return low, high


def rebound_with_shell_loss(test: RuleBookTest, eta: float, rtol: float = 1e-9) -> float:
    """The rebound (m, through the air) of ``test``'s ball with the shell material's loss
    factor ``eta`` (dimensionless), the rest of the ball its preset's."""
    from synth.io.presets import load_preset
    from synth.physics.materials import LossFactor
    from synth.physics.scene import HollowBall

    ball = load_preset(test.preset).ball
    material = dataclasses.replace(ball.material, damping=LossFactor(eta))
    other = HollowBall(
        material,
        ball.radius,
        thickness=ball.thickness,
        pressure=ball.pressure,
        cover_thickness=ball.cover_thickness,
        cover_mass=ball.cover_mass,
    )
    return _drop_through_air(test, other, rtol).rebound


#: The largest shell loss factor :func:`shell_loss_to_land` searches (dimensionless; a
#: :class:`~synth.physics.materials.LossFactor` is below 1): beyond it the diagnosis reports
#: "above" it.
DIAGNOSIS_MAX_LOSS = 0.99


def wall_energy_share(ball, deflection: float) -> float:
    """The share (dimensionless) of the elastic energy at the deflection ``deflection`` (m)
    that the shell's wall holds, the rest the gas' (``U_s / (U_s + U_g)`` of the shell law's
    potentials, :func:`~synth.physics.contact_kernels.shell.shell_potential`): the only
    share the shell material's loss acts on (docs/physics.md, "Hollow balls")."""
    from synth.physics.contact_kernels.shell import shell_potential
    from synth.physics.contact_law import shell_law

    law = shell_law(ball)
    wall = shell_potential(deflection, law.reissner_stiffness, law.transition, 0.0)
    gas = shell_potential(deflection, 0.0, law.transition, law.gas_stiffness)
    return wall / (wall + gas)


def shell_loss_to_land(test: RuleBookTest, rebound: float, rtol: float = 1e-9) -> float | None:
    """The shell material's loss factor (dimensionless) with which ``test``'s ball, the
    rest of it its preset's, rebounds to ``rebound`` (m, through the air): a diagnosis of
    the loss the engine misses, never a value the engine takes. ``None`` where even
    :data:`DIAGNOSIS_MAX_LOSS` leaves the ball above ``rebound``."""
    from scipy.optimize import brentq

    def miss(eta: float) -> float:
        return rebound_with_shell_loss(test, eta, rtol) - rebound

    if miss(DIAGNOSIS_MAX_LOSS) > 0.0:
        return None
    return brentq(miss, 0.0, DIAGNOSIS_MAX_LOSS, xtol=1e-4)


#: Thermal diffusivity of air at 300 K and one atmosphere, m^2/s (F. P. Incropera, D. P.
#: DeWitt, T. L. Bergman & A. S. Lavine, "Fundamentals of Heat and Mass Transfer", 6th ed.
#: (Wiley 2007), Table A.4, air at 300 K: alpha = 22.5e-6 m^2/s); it scales as 1 / pressure.
AIR_THERMAL_DIFFUSIVITY = 22.5e-6
#: The ratio of air's specific heats, dimensionless (ideal diatomic gas, 7/5).
AIR_HEAT_CAPACITY_RATIO = 1.4


def gas_thermal_loss_share(ball, row: HollowRow, speed: float) -> float:
    """An estimate of the share (dimensionless) of a hollow ``ball``'s impact energy (at the
    impact ``speed``, m/s) that the gas' heat exchange with the wall takes in ``row``'s
    contact (docs/physics.md, "Hollow balls"): the gas in a cavity of volume ``V`` and wall
    area ``S`` under a pressure cycle of angular frequency ``omega`` behaves isothermally in
    the thermal boundary layer ``d = sqrt(2 alpha / omega)`` at the wall, whose phase lag
    gives the gas spring a loss factor ``eta_g = (gamma - 1) S d / (2 V)``, acting on the
    compression energy ``gamma p_abs dV^2 / (2 V)`` of the cap's volume ``dV = pi delta^2
    (R_i - delta / 3)``; one compression and release take ``pi eta_g`` of it. ``omega`` is
    the contact's ``pi / tau``."""
    from synth.physics.scene import ATMOSPHERE

    gamma = AIR_HEAT_CAPACITY_RATIO
    absolute = ATMOSPHERE + ball.pressure
    alpha = AIR_THERMAL_DIFFUSIVITY * ATMOSPHERE / absolute
    layer = math.sqrt(2.0 * alpha * row.contact_time / math.pi)
    radius = ball.inner_radius
    volume = 4.0 / 3.0 * math.pi * radius**3
    eta = (gamma - 1.0) * 4.0 * math.pi * radius**2 * layer / (2.0 * volume)
    d = row.deflection
    cap = math.pi * d * d * (radius - d / 3.0)
    compression = gamma * absolute * cap * cap / (2.0 * volume)
    return math.pi * eta * compression / (0.5 * ball.mass * speed * speed)


def rise_speed(height: float, v_t: float) -> float:
    """The speed (m/s) at which a ball thrown up with quadratic drag (terminal speed ``v_t``,
    m/s) reaches ``height`` (m): :func:`rise_height` inverted, ``v = v_t sqrt(exp(2 g h /
    v_t^2) - 1)``."""
    return v_t * math.sqrt(math.expm1(2.0 * GRAVITY * height / (v_t * v_t)))


def missing_loss_share(test: RuleBookTest, row: HollowRow, ball) -> float:
    """The share (dimensionless) of ``test``'s impact energy that ``row``'s impact would have
    to lose beyond the engine's loss for the ball to rebound through the air to the top of
    the rule book's range: ``e^2 - e_top^2``, ``e_top`` the restitution that gives that
    rebound (:func:`rise_speed` over the impact speed)."""
    v_t = terminal_speed(ball.mass, ball.radius, test.drag_coefficient)
    top = test.rebound_high - (2.0 * ball.radius if test.to_top else 0.0)
    e_top = rise_speed(top, v_t) / fall_speed(test.drop, v_t)
    return row.restitution**2 - e_top**2


#: The highest order ``n`` of the shell's axisymmetric modes :func:`ringing_bound` sums
#: (dimensionless): far above the contact's frequency the pulse's spectrum leaves them nothing.
RINGING_MAX_ORDER = 60


def hayek_coefficients(ball, n: int) -> tuple[float, float, float]:
    """``(P, Q, scale)`` of Hayek's frequency equation ``L^2 - P L + Q = 0`` of ``ball``'s
    shell at the order ``n`` (:func:`shell_mode_frequencies`): ``P`` and ``Q`` dimensionless,
    ``scale = sqrt(E / (rho (1 - nu^2))) / R`` (rad/s) with ``omega = scale sqrt(L)``."""
    mat = ball.material
    nu, h = mat.poisson, ball.thickness
    radius = ball.shell_radius - 0.5 * h
    a, b = h * h / (12.0 * radius * radius), n * (n + 1.0)
    p = 1.0 + 3.0 * nu - a * (1.0 - nu) + b * (1.0 + a * nu + a * b)
    q = a * b * (b * b - 4.0 * b + 5.0 - nu * nu) + (1.0 - nu * nu) * (b - 2.0 * (1.0 + a))
    return p, q, math.sqrt(mat.young / (mat.density * (1.0 - nu * nu))) / radius


def shell_mode_frequencies(ball, n: int) -> tuple[float, ...]:
    """The angular frequencies (rad/s, ascending) of the axisymmetric modes of order ``n``
    (Legendre ``P_n``) of ``ball``'s free spherical shell: the positive roots of S. Hayek's
    frequency equation (membrane theory with the bending correction; "Vibrations of a
    spherical shell in an acoustic medium", J. Acoust. Soc. Am. 40 (1966) 342, as the
    code_aster validation manual V2.03.007 states it),

        L^2 - L [1 + 3 nu - a (1 - nu) + b (1 + a nu + a b)]
            + a b (b^2 - 4 b + 5 - nu^2) + (1 - nu^2) (b - 2 (1 + a)) = 0,

    ``L = lambda^2``, ``a = h^2 / (12 R^2)``, ``b = n (n + 1)``, ``omega = lambda / R
    sqrt(E / (rho (1 - nu^2)))`` with ``R`` the wall's mid-surface radius. The gauge
    pressure's prestress (:mod:`benchmarks.hollow_modes`) and the cover's mass are left out.
    For ``n = 1`` the lower root is the ball's translation (0), which is left out."""
    p, q, scale = hayek_coefficients(ball, n)
    root = math.sqrt(p * p - 4.0 * q)
    roots = [0.5 * (p - root), 0.5 * (p + root)]
    return tuple(scale * math.sqrt(L) for L in roots if L > 1e-9 * p)


def radial_share(ball, n: int, omega: float) -> float:
    """The share (dimensionless, in (0, 1]) of a mode's kinetic energy in its radial motion,
    for the axisymmetric mode of order ``n`` at the angular frequency ``omega`` (rad/s) of
    ``ball``'s shell: the membrane equations of the sphere (radial ``w = W P_n``, tangential
    ``u = U dP_n / d theta``; ``b = n (n + 1)``, ``O^2 = rho (1 - nu^2) R^2 omega^2 / E``)

        (b - (1 - nu) - O^2) U + (1 + nu) W = 0,   (1 + nu) b U + (2 (1 + nu) - O^2) W = 0,

    whose determinant is Hayek's equation without its bending term
    (:func:`shell_mode_frequencies`), give ``U / W = (O^2 - 2 (1 + nu)) / ((1 + nu) b)``;
    over the sphere ``P_n^2`` and ``(dP_n / d theta)^2`` integrate in the ratio ``1 : b``, so
    the share is ``1 / (1 + b (U / W)^2)``. Over the two modes of an order the shares sum to 1
    (their shapes are orthogonal), 1/3 of ``n = 1``'s being the translation's."""
    mat = ball.material
    nu = mat.poisson
    radius = ball.shell_radius - 0.5 * ball.thickness
    b = n * (n + 1.0)
    if b == 0.0:
        return 1.0
    o2 = mat.density * (1.0 - nu * nu) * radius * radius * omega * omega / mat.young
    ratio = (o2 - 2.0 * (1.0 + nu)) / ((1.0 + nu) * b)
    return 1.0 / (1.0 + b * ratio * ratio)


def pulse_spectrum(result, omegas, points: int = 20001) -> np.ndarray:
    """``|F(omega)|`` (N s) of an impact's force pulse at the angular frequencies ``omegas``
    (rad/s), ``int F(t) exp(-i omega t) dt`` over the contact (trapezoid rule on ``points``
    samples of the engine's own pulse, sampled once)."""
    t = np.linspace(0.0, result.separation_time, points)
    force = result.force_at(t)
    return np.array([abs(np.trapezoid(force * np.exp(-1j * w * t), t)) for w in omegas])


def _shell_modes(ball) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every axisymmetric mode of ``ball``'s shell up to :data:`RINGING_MAX_ORDER`: its order
    ``n``, angular frequency (rad/s, :func:`shell_mode_frequencies`) and radial share
    (:func:`radial_share`)."""
    modes = [
        (n, w, radial_share(ball, n, w))
        for n in range(RINGING_MAX_ORDER + 1)
        for w in shell_mode_frequencies(ball, n)
    ]
    order, omega, share = (np.array(column, dtype=float) for column in zip(*modes, strict=True))
    return order, omega, share


def ringing_bound(ball, result) -> float:
    """An upper bound (J) of the energy the engine's force pulse ``result`` leaves in
    ``ball``'s shell modes after the contact (the wall's ringing, lost to the rebound), were
    the shell driven by that pulse at the contact point, its pole: each mode an undamped
    oscillator, left with ``phi^2 |F(omega)|^2 / (2 M)`` when the force ends. The
    axisymmetric modes of order ``n`` share the radial motion ``P_n(cos theta)``, whose mass
    is ``m_s / (2 n + 1)`` (``m_s`` the shell's): over the order's modes ``phi^2 / M`` sums to
    at most ``(2 n + 1) / m_s`` (``2 / m_s`` for ``n = 1`` beside the translation), so the
    order leaves at most that times the largest ``|F(omega)|^2 / 2`` of its modes
    (:func:`shell_mode_frequencies`, :func:`pulse_spectrum`). Driving the shell with the
    quasi-static pulse is a first-order picture: it holds where the modes lie well above the
    contact's frequency; nearer, they take part in the contact itself."""
    order, omega, _ = _shell_modes(ball)
    energy = pulse_spectrum(result, omega) ** 2
    total = 0.0
    for n in range(RINGING_MAX_ORDER + 1):
        weight = 2.0 if n == 1 else 2.0 * n + 1.0
        total += weight * energy[order == n].max() / (2.0 * ball.shell_mass)
    return total


def ringing_estimate(ball, result, raised: float = 1.0) -> float:
    """An estimate (J) of the energy the engine's force pulse ``result`` leaves in ``ball``'s
    shell modes (:func:`ringing_bound`'s oscillators): each mode of order ``n`` at ``omega``
    takes ``(2 n + 1) s |F(omega)|^2 / (2 m_s)``, ``s`` its radial share
    (:func:`radial_share`; its shape the membrane's, its frequency Hayek's). ``raised``
    (dimensionless) multiplies every mode's frequency, shape and share kept: the estimate's
    sensitivity to the frequencies (the pulse's spectrum falls steeply above the contact's)."""
    order, omega, share = _shell_modes(ball)
    spectrum = pulse_spectrum(result, raised * omega)
    return float(np.sum((2.0 * order + 1.0) * share * spectrum**2) / (2.0 * ball.shell_mass))


#: The factor on every mode's frequency for the sensitivity :class:`Ringing` prints
#: (dimensionless): 10 % higher modes.
RINGING_RAISED = 1.1


@dataclass(frozen=True)
class Ringing:
    """The wall's ringing in a rule-book test's impact: the shell's lowest mode over the
    contact's angular frequency ``pi / tau`` (``ratio``), :func:`ringing_bound`'s and
    :func:`ringing_estimate`'s shares of the impact energy (``bound``, ``estimate``; ``raised``
    with every mode :data:`RINGING_RAISED` times higher), and the rebound (m, through the air)
    were the estimate taken off the engine's (``rebound``): a diagnosis, not the engine's
    bounce (all dimensionless but ``rebound``)."""

    ratio: float
    bound: float
    estimate: float
    raised: float
    rebound: float


def ringing(test: RuleBookTest, ball, rtol: float = 1e-9) -> Ringing:
    """``test``'s impact of ``ball`` through the air (as :func:`rule_book_row`'s) and its
    :class:`Ringing`."""
    v_t = terminal_speed(ball.mass, ball.radius, test.drag_coefficient)
    speed = fall_speed(test.drop, v_t)
    impact = solve_impact(ball, test.surface, speed, contact="shell", rtol=rtol)
    lowest = _shell_modes(ball)[1].min()
    energy = 0.5 * ball.mass * speed * speed
    estimate = ringing_estimate(ball, impact) / energy
    e = math.sqrt(max(impact.restitution**2 - estimate, 0.0))
    top = 2.0 * ball.radius if test.to_top else 0.0
    return Ringing(
        lowest * impact.contact_time / math.pi,
        ringing_bound(ball, impact) / energy,
        estimate,
        ringing_estimate(ball, impact, RINGING_RAISED) / energy,
        rise_height(e * speed, v_t) + top,
    )


def ringing_note(test: RuleBookTest, ball, row: HollowRow) -> str:
    """The part of a loss-budget line on the wall's ringing (:func:`ringing`), beside the
    loss the engine misses (:func:`missing_loss_share`)."""
    ring = ringing(test, ball)
    missing = missing_loss_share(test, row, ball)
    return (
        f"the wall's ringing: its lowest mode lies at {ring.ratio:.1f} times the contact's "
        f"frequency `pi / tau` (the free elastic shell's, without its gauge pressure), and "
        f"the engine's pulse leaves about {ring.estimate:.1e} of the impact energy in the "
        f"shell's modes (at most {ring.bound:.1e}; {ring.raised:.1e} were every mode "
        f"{100.0 * (RINGING_RAISED - 1.0):.0f} % higher), against the {missing:.1e} of it the "
        f"impact would have to lose besides the engine's loss to rebound to the range's top; "
        f"were the estimate taken off the rebound, the ball would rise to {ring.rebound:.3f} m "
        f"(a diagnosis, not the engine's bounce)"
    )


def loss_budget_note(test: RuleBookTest, row: HollowRow) -> str:
    """A line of docs/validation.md: the share of ``test``'s impact energy its shell's loss
    acts on, and the loss factor the shell would need to carry the missing loss alone."""
    from synth.io.presets import load_preset

    ball = load_preset(test.preset).ball
    share = wall_energy_share(ball, row.deflection)
    needed = [shell_loss_to_land(test, h) for h in (test.rebound_high, test.rebound_low)]
    if needed[0] is None:
        land = f"no loss factor up to {DIAGNOSIS_MAX_LOSS:g} brings it down to the range"
    else:
        low = f"{needed[1]:.3f}" if needed[1] is not None else f"above {DIAGNOSIS_MAX_LOSS:g}"
        land = (
            f"to carry the missing loss by itself it would need {needed[0]:.3f} for the "
            f"range's top and {low} for its bottom"
        )
    if ball.pressure == 0.0:
        holds = "without gauge pressure the wall holds all the elastic energy"
    else:
        holds = (
            f"at its peak deflection the wall holds {100.0 * share:.0f} % of the elastic "
            f"energy, the gas the rest"
        )
    v_t = terminal_speed(ball.mass, ball.radius, test.drag_coefficient)
    thermal = gas_thermal_loss_share(ball, row, fall_speed(test.drop, v_t))
    return (
        f"- {test.ball}, the loss budget: {holds}; the gas' heat exchange with the wall "
        f"takes about {thermal:.1e} of the impact energy (an estimate of its order: the "
        f"thermal boundary layer), the engine none; {ringing_note(test, ball, row)}; the shell's "
        f"loss factor "
        f"({ball.material.damping.eta:g}) acts on the wall's share only; {land} "
        f"(a diagnosis of the missing loss, not a value the engine takes)."
    )


def loss_range_note(test: RuleBookTest) -> str:
    """A line of docs/validation.md: ``test``'s rebound over its shell's published loss
    factors."""
    from synth.io.presets import load_preset

    low, high = test.loss_range
    table = load_preset(test.preset).ball.material.damping.eta
    most, least = rebounds_over_loss_range(test)
    return (
        f"- {test.ball}: with the shell's loss factor at the ends of its published range, "
        f"{low:g}-{high:g} ({test.loss_source}; the table takes {table:g}), the rebound "
        f"through the air is {least:.3f}-{most:.3f} m."
    )


#: The ITF's static test of a tennis ball (Rules of Tennis, Appendix I, ball types 2 and 3):
#: its "forward deformation" under an 18 lb (8.165 kg) load along a diameter, m; the test's
#: pre-load and pre-compression (the ITF's test methods) have not been read.
ITF_DEFORMATION_LOAD = 8.165 * 9.80665
ITF_FORWARD_DEFORMATION = (5.59e-3, 7.37e-3)


def shell_elastic_force(law, delta):
    """The elastic force ``F_e`` (N) of a :class:`~synth.physics.contact_law.ShellLaw` at the
    deflection ``delta`` (m, >= 0): ``min(k_R delta, C_P delta^(1/2)) + k_g delta``."""
    d = np.asarray(delta, dtype=float)
    shell = np.minimum(law.reissner_stiffness * d, law.pogorelov_constant * np.sqrt(d))
    return shell + law.gas_stiffness * d


def static_compression(ball, load: float) -> float:
    """The shortening (m) of a hollow ``ball``'s diameter pressed between two rigid flats by
    ``load`` (N): twice the deflection of one flat contact whose elastic force (the shell
    law's, :func:`shell_elastic_force`) is ``load``."""
    from scipy.optimize import brentq

    from synth.physics.contact_law import shell_law

    law = shell_law(ball)
    upper = load / law.stiffness
    while shell_elastic_force(law, upper) < load:  # beyond delta_t the law is softer than k0
        upper *= 2.0
    return 2.0 * brentq(lambda d: float(shell_elastic_force(law, d)) - load, 0.0, upper, xtol=1e-15)


def itf_deformation_note() -> str:
    """A line of docs/validation.md: the engine's tennis ball in the ITF's static test."""
    from synth.io.presets import load_preset

    ball = load_preset("tennis-ball-on-concrete").ball
    low, high = ITF_FORWARD_DEFORMATION
    engine = static_compression(ball, ITF_DEFORMATION_LOAD)
    verdict = "inside" if low <= engine <= high else "outside"
    return (
        f"- tennis, statically: under the ITF's {ITF_DEFORMATION_LOAD:.1f} N along a diameter "
        f"(Rules of Tennis, Appendix I, 'forward deformation') the engine's ball shortens "
        f"{1e3 * engine:.2f} mm, {verdict} the rule book's {1e3 * low:.2f}-{1e3 * high:.2f} mm "
        f"(the core's wall, rubber, pressure and felt from their sources, docs/materials.md, "
        f"'The tennis ball'; not fitted to this test)."
    )


def run_hollow() -> list[HollowRow]:
    """Every rule book's test (:data:`RULE_BOOK_TESTS`)."""
    return [rule_book_row(t) for t in RULE_BOOK_TESTS]


def _published_contact(test: RuleBookTest) -> str:
    if test.contact_time is None:
        return "none read"
    return f"about {1e3 * test.contact_time:g} ({test.contact_source})"


def format_hollow(rows: list[HollowRow]) -> str:
    """The rule-book table of docs/validation.md, "Hollow balls"."""
    from benchmarks.hollow_modes import modes_note

    header = [
        "ball",
        "surface",
        "rule book (source)",
        "drop (m)",
        "required rebound (m)",
        "drag coefficient (source)",
        "engine rebound (m)",
        "engine rebound without drag (m)",
        "engine e",
        "error",
        "engine contact time (ms)",
        "published contact time (ms, source)",
        "contact time error",
        "engine peak deflection (mm)",
    ]
    lines = []
    for row in rows:
        t = row.test
        error = "inside" if row.error == 0.0 else f"{100.0 * row.error:+.0f} %"
        lines.append(
            [
                t.ball,
                t.surface_name,
                t.source,
                f"{t.drop:g}",
                f"{t.rebound_low:g}-{t.rebound_high:g}",
                f"{t.drag_coefficient:g} ({t.drag_source})",
                f"{row.rebound:.3f}",
                f"{row.rebound_in_vacuum:.3f}",
                f"{row.restitution:.3f}",
                error,
                f"{1e3 * row.contact_time:.2f}",
                _published_contact(t),
                ""
                if row.contact_time_error is None
                else f"{100.0 * row.contact_time_error:+.0f} %",
                f"{1e3 * row.deflection:.2f}",
            ]
        )
    notes = [f"- {r.test.ball}: {r.test.note}." for r in rows if r.test.note]
    notes.append(itf_deformation_note())
    notes += [loss_range_note(r.test) for r in rows if r.test.loss_range is not None]
    notes += [loss_budget_note(r.test, r) for r in rows]
    notes += [modes_note(r.test) for r in rows]
    return "\n".join(markdown_table(header, lines) + ([""] + notes if notes else [])) + "\n"
