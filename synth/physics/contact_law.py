"""The contact law of a ball on a plate from their materials and sizes: Hertz, Hunt-Crossley,
viscoelastic Hertz with each material's loss, the layered surface's foundation, and the
measured surfaces (docs/physics.md, "Hertz contact" and "Contact losses")."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from synth import checks
from synth.errors import ParameterError
from synth.physics.materials import LossFactor, contact_surface, has_contact_surface
from synth.physics.materials import get as get_material
from synth.physics.scene import (
    CONTACT_LAWS,
    LAW_OPTIONS,
    SURFACE_MODELS,
    Ball,
    HollowBall,
    Plate,
    check_law_options,
)


def effective_modulus(ball: Ball, plate: Plate, transverse_ratio: float = 1.0) -> float:
    """Contact modulus ``E*`` with ``1/E* = 1/E'_ball + 1/E'_plate``, Pa, the plate's modulus
    times ``transverse_ratio`` (dimensionless)."""
    plate_modulus = transverse_ratio * plate.material.effective_modulus
    return 1.0 / (1.0 / ball.material.effective_modulus + 1.0 / plate_modulus)


def hertz_stiffness(ball: Ball, plate: Plate, transverse_ratio: float = 1.0) -> float:
    """Hertz constant ``K = 4/3 sqrt(R) E*`` of a sphere on a flat (thesis 2.9-2.11), N/m^1.5,
    ``E*`` as :func:`effective_modulus`'s."""
    return 4.0 / 3.0 * math.sqrt(ball.radius) * effective_modulus(ball, plate, transverse_ratio)


def foundation_stiffness(ball: Ball, plate: Plate, depth: float | None = None) -> float:
    """Elastic-foundation constant ``K = pi E'_plate R / h`` (thesis 4.3.2), N/m^2; ``depth``
    the Winkler layer's ``h``, m (default: the plate thickness)."""
    h = plate.thickness if depth is None else checks.positive("layer_depth", depth, "metres")
    return math.pi * plate.material.effective_modulus * ball.radius / h


@dataclass(frozen=True)
class ContactLaw:
    """The constants of a contact law (docs/physics.md, "Hertz contact" and "Contact losses"):
    ``stiffness`` ``K`` (N/m^n), ``exponent`` ``n``, Hunt-Crossley ``dissipation`` (s/m),
    ``viscous_time`` (s), a hollow ball's ``shell`` law, ``yield_penetration`` (m; inf: none)."""

    stiffness: float
    exponent: float
    dissipation: float = 0.0
    viscous_time: float = 0.0
    shell: ShellLaw | None = None
    yield_penetration: float = math.inf


#: Pogorelov's constant of the flattened spherical shell with its inverted (mirror-buckled) cap, ``F
#: = C (E h^(5/2) / (R (1 - nu^2)^(3/4))) delta^(1/2)`` (A. V. Pogorelov, "Bendings of Surfaces and
#: Stability of Shells", AMS Translations of Mathematical Monographs 72, 1988), dimensionless.
POGORELOV_CONSTANT = 3.56


@dataclass(frozen=True)
class ShellLaw:
    """The thin-shell contact of a hollow ball on a flat (docs/physics.md, "Hollow balls"): ``F =
    min(k_R delta, C_P delta^(1/2)) + k_g delta`` with a Kelvin-Voigt loss: ``reissner_stiffness``
    (N/m), ``pogorelov_constant`` (N/m^(1/2)), ``gas_stiffness`` ``2 pi R p`` (N/m, the gauge
    pressure on the flat area ``pi (2 R delta)``), ``viscous_time`` (s)."""

    reissner_stiffness: float
    pogorelov_constant: float
    gas_stiffness: float
    viscous_time: float = 0.0

    @property
    def stiffness(self) -> float:
        """``k0 = k_R + k_g``, the law's stiffness at small deflection, N/m."""
        return self.reissner_stiffness + self.gas_stiffness

    @property
    def transition(self) -> float:
        """Deflection (m) where Reissner's and Pogorelov's laws meet (the smaller force holds)."""
        return (self.pogorelov_constant / self.reissner_stiffness) ** 2


def reissner_stiffness(ball: HollowBall) -> float:
    """``k_R = 4 E h^2 / (R sqrt(3 (1 - nu^2)))`` (N/m): E. Reissner, "Stresses and small
    displacements of shallow spherical shells", J. Math. Phys. 25 (1946) 80 and 279 (the
    point load on a spherical shell)."""
    E, nu, h, R = ball.material.young, ball.material.poisson, ball.thickness, ball.shell_radius
    return 4.0 * E * h * h / (R * math.sqrt(3.0 * (1.0 - nu * nu)))


def pogorelov_constant(ball: HollowBall) -> float:
    """``C_P = 3.56 E h^(5/2) / (R (1 - nu^2)^(3/4))`` (N/m^(1/2)), :data:`POGORELOV_CONSTANT`."""
    E, nu, h, R = ball.material.young, ball.material.poisson, ball.thickness, ball.shell_radius
    return POGORELOV_CONSTANT * E * h**2.5 / (R * (1.0 - nu * nu) ** 0.75)


def shell_law(ball: HollowBall) -> ShellLaw:
    """The :class:`ShellLaw` of ``ball``. Left out: the plate's indentation (the force spreads
    over a disc of radius ``sqrt(2 R delta)`` on a far stiffer plate) and the gas' compression
    (second order). Loss: Kelvin-Voigt, ``A = eta / omega_c``, ``omega_c = sqrt(k0 / m)``."""
    kR = reissner_stiffness(ball)
    cP = pogorelov_constant(ball)
    kg = 2.0 * math.pi * ball.shell_radius * ball.pressure
    omega = math.sqrt((kR + kg) / ball.mass)
    A = _contact_loss_factor(ball, "ball", omega) / omega
    return ShellLaw(kR, cP, kg, A)


def own_law(ball: Ball) -> str:
    """A ball's law when none is named: "shell" for a hollow ball (its only law), else "hertz"."""
    return "shell" if isinstance(ball, HollowBall) else "hertz"


def resolved_surface(plate: Plate, law: str, surface: str) -> str:
    """The plate's side that ``surface`` names for ``law``: "auto" is "fitted" for Hertz on a
    material with a fitted surface, else "material"; "ideal" for other laws."""
    if surface != "auto":
        return surface
    if law != "hertz":
        return "ideal"
    return "fitted" if has_contact_surface(plate.material) else "material"


#: Impact speed (m/s) at which a material's loss factor sets its share of the viscoelastic
#: contact's dissipative time (:func:`material_viscous_time`): at other speeds the loss
#: follows the viscoelastic Hertz law's own ``1 - e ~ v^(1/5)``.
LOSS_REFERENCE_SPEED = 1.0
#: Contact time of the elastic Hertz impact on a rigid flat without gravity over
#: ``delta_max / v`` (closed form, docs/physics.md, "Hertz contact").
HERTZ_TIME_FACTOR = 2.9433


def material_loss_factor(material, omega: float) -> float:
    """Loss factor ``eta`` of ``material``'s damping law at ``omega`` (rad/s), 0 without one."""
    d = material.damping
    if d is None:
        return 0.0
    if isinstance(d, LossFactor):
        return d.eta
    return d.alpha / omega + d.beta * omega


def hertz_contact_time(mass: float, stiffness: float, speed: float) -> float:
    """Contact time (s) of the elastic Hertz impact ``F = K delta^(3/2)`` of a ball of
    ``mass`` (kg) on a rigid flat at ``speed`` (m/s), without gravity:
    ``2.9433 delta_max / v``, ``delta_max = (5 m v^2 / (4 K))^(2/5)``."""
    delta_max = (5.0 * mass * speed * speed / (4.0 * stiffness)) ** 0.4
    return HERTZ_TIME_FACTOR * delta_max / speed


def material_viscous_time(
    ball: Ball, plate: Plate, transverse_ratio: float = 1.0, plate_share: float | None = None
) -> float:
    """Dissipative time ``A`` (s) of the viscoelastic Hertz contact from the materials' loss
    factors (docs/physics.md, "Contact losses"): Kelvin-Voigt bodies, ``A_i = eta_i /
    omega_c`` at :data:`LOSS_REFERENCE_SPEED`, compliances adding, ``A = E* sum_i A_i / E'_i``.
    ``plate_share`` (s) replaces the plate's term (None: its material's)."""
    K = hertz_stiffness(ball, plate, transverse_ratio)
    omega_c = math.pi / hertz_contact_time(ball.mass, K, LOSS_REFERENCE_SPEED)
    ball_modulus = ball.material.effective_modulus
    plate_modulus = transverse_ratio * plate.material.effective_modulus
    e_star = effective_modulus(ball, plate, transverse_ratio)
    ball_term = e_star / ball_modulus * _contact_loss_factor(ball, "ball", omega_c) / omega_c
    if plate_share is None:
        plate_share = (
            e_star / plate_modulus * _contact_loss_factor(plate, "plate", omega_c) / omega_c
        )
    return ball_term + plate_share


def _contact_loss_factor(body, name: str, omega: float) -> float:
    """:func:`material_loss_factor` at ``omega`` (rad/s), else ``ParameterError`` when not below
    1 (a solid's bound, which a Rayleigh law can exceed)."""
    eta = material_loss_factor(body.material, omega)
    if not eta < 1.0:
        raise ParameterError(
            f"{name}.material.damping={body.material.damping!r}: its loss factor at the "
            f"contact's frequency {omega / (2.0 * math.pi):.4g} Hz is {eta:.3g}; a solid's "
            f"loss factor is below 1"
        )
    return eta


def fitted_viscous_time(ball: Ball, plate: Plate, surface) -> float:
    """Dissipative time ``A`` (s) with a fitted ``surface`` (fitted with a steel ball): the board's
    term scaled by the ball's share of the indentation, the ball's own term replacing steel's."""
    steel = replace(ball, material=get_material("steel"), mass=ball.mass)
    plate_modulus = surface.transverse_ratio * plate.material.effective_modulus
    ball_modulus = ball.material.effective_modulus
    steel_modulus = steel.material.effective_modulus
    share = ball_modulus / (ball_modulus + plate_modulus)
    share_fit = steel_modulus / (steel_modulus + plate_modulus)
    own = material_viscous_time(ball, plate, surface.transverse_ratio, plate_share=0.0)
    steel_own = material_viscous_time(steel, plate, surface.transverse_ratio, plate_share=0.0)
    return surface.viscous_time * (share / share_fit) + (own - steel_own)


def _check_surface_alone(surface: str, contact: str, given: dict) -> None:
    """Refuse another law, or any law argument, beside a measured surface."""
    why = {
        "fitted": "the fit is of a Hertz contact with its own loss",
        "material": "the materials' loss is a viscoelastic Hertz contact's",
    }[surface]
    if contact != "hertz":
        raise ParameterError(
            f"surface={surface!r} applies to contact='hertz' only, not {contact!r} ({why})"
        )
    for key, value in given.items():
        if value is not None:
            raise ParameterError(f"{key}={value!r} does not apply to surface={surface!r}")


def _measured_law(ball: Ball, plate: Plate, surface: str) -> ContactLaw:
    """The Hertz law of a measured ``surface`` with its loss and the materials' yield."""
    if surface == "material":
        K = hertz_stiffness(ball, plate)
        mu, A = 0.0, material_viscous_time(ball, plate)
    else:
        fit = contact_surface(plate.material)
        K = hertz_stiffness(ball, plate, fit.transverse_ratio)
        if fit.viscous_time == 0.0:  # a Hunt-Crossley surface: its loss alone
            mu, A = fit.dissipation, 0.0
        else:
            mu, A = 0.0, fitted_viscous_time(ball, plate, fit)
    return ContactLaw(K, 1.5, mu, A, yield_penetration=yield_penetration(ball, plate, K))


def contact_parameters(
    ball: Ball, plate: Plate, contact: str | None = "hertz", *, surface: str = "ideal", **options
) -> ContactLaw:
    """The constants of a named ``contact`` law (docs/physics.md, "Hertz contact"), None the
    ball's own. ``surface`` "ideal": an isotropic elastic half-space (the thesis' model);
    "fitted" (Hertz only): the material's fitted surface; "auto": the model closest to
    measurement. ``options``, required by their law and refused by others: Hunt-Crossley's
    ``dissipation`` (s/m); the viscoelastic ``viscous_time`` ``A`` (s) of ``F = K (delta^(3/2)
    + (3/2) A delta^(1/2) d(delta)/dt)`` (Kuwabara & Kono 1987; Brilliantov et al. 1996);
    "power-law"'s ``exponent`` in (1, 4] and ``stiffness`` (N/m^n); "elastic-foundation"'s
    ``layer_depth`` (m, default the plate's thickness)."""
    for key in options:
        checks.choice("contact parameter", key, LAW_OPTIONS)
    given = {key: options.get(key) for key in LAW_OPTIONS}
    if contact is None:
        contact = own_law(ball)
    checks.choice("contact", contact, CONTACT_LAWS)
    checks.choice("surface", surface, SURFACE_MODELS)
    if isinstance(ball, HollowBall) or contact == "shell":
        return _shell_parameters(ball, contact, surface, given)
    surface = resolved_surface(plate, contact, surface)
    if surface in ("fitted", "material"):
        _check_surface_alone(surface, contact, given)
        return _measured_law(ball, plate, surface)
    check_law_options(contact, given)
    if contact == "elastic-foundation":
        return ContactLaw(foundation_stiffness(ball, plate, given["layer_depth"]), 2.0)
    if contact == "power-law":
        return ContactLaw(
            checks.positive("stiffness", given["stiffness"], "N/m^n"),
            checks.in_range(
                "exponent", given["exponent"], 1.0, 4.0, "dimensionless", hi_open=False
            ),
        )
    mu, A = given["dissipation"], given["viscous_time"]
    return ContactLaw(
        hertz_stiffness(ball, plate), 1.5,
        0.0 if mu is None else checks.positive("dissipation", mu, "s/m"),
        0.0 if A is None else checks.positive("viscous_time", A, "s"),
    )  # fmt: skip


def _shell_parameters(ball, contact, surface, given: dict) -> ContactLaw:
    """The thin-shell law's constants: a :class:`HollowBall` under ``contact="shell"`` only."""
    if not isinstance(ball, HollowBall):
        raise ParameterError(
            f"contact={contact!r} applies to a HollowBall only (a thin shell), not {ball!r}"
        )
    if contact != "shell":
        raise ParameterError(
            f"contact={contact!r}: a HollowBall's contact is the thin-shell law, contact='shell' "
            f"(docs/physics.md, 'Hollow balls')"
        )
    if surface not in ("ideal", "auto"):
        raise ParameterError(
            f"surface={surface!r} does not apply to contact='shell' (the shell carries its "
            f"own loss; allowed: 'ideal', 'auto')"
        )
    if any(value is not None for value in given.values()):
        raise ParameterError(
            "contact='shell' takes no law parameters (dissipation, viscous_time, exponent, "
            "stiffness, layer_depth): the shell's own geometry and material set them"
        )
    law = shell_law(ball)
    return ContactLaw(law.stiffness, 1.0, viscous_time=law.viscous_time, shell=law)


#: Mean pressure of a fully plastic indentation by a sphere over the yield stress, the
#: hardness ``H = 2.8 Y`` (D. Tabor, "The Hardness of Metals", Oxford 1951; K. L. Johnson,
#: "Contact Mechanics", Cambridge UP 1985, section 6.2, gives about 3), dimensionless.
TABOR_CONSTRAINT = 2.8


def yield_pressure(ball: Ball, plate: Plate) -> float | None:
    """Limiting contact pressure (Pa): ``2.8 Y`` of the smaller yield stress; None without one."""
    stresses = [
        m.yield_stress for m in (ball.material, plate.material) if m.yield_stress is not None
    ]
    return TABOR_CONSTRAINT * min(stresses) if stresses else None


def yield_speed(ball: Ball, plate: Plate) -> float | None:
    """Impact speed (m/s) at which the elastic Hertz impact's peak pressure reaches
    :func:`yield_pressure`, ``V_y = (pi / (2 E*))^2 (8 pi R^3 p_y^5 / (15 m))^(1/2)`` (C.
    Thornton, J. Appl. Mech. 64 (1997) 383). None without a yield stress; ``ParameterError``
    for a hollow ball."""
    if isinstance(ball, HollowBall):
        raise ParameterError(
            f"ball={ball!r}: a HollowBall's contact is the thin-shell law, which has no "
            f"Hertz yield speed"
        )
    p_y = yield_pressure(ball, plate)
    if p_y is None:
        return None
    e_star = effective_modulus(ball, plate)
    R = ball.radius
    return (math.pi / (2.0 * e_star)) ** 2 * math.sqrt(
        8.0 * math.pi * R**3 * p_y**5 / (15.0 * ball.mass)
    )


def plastic_restitution(speed: float, v_yield: float | None) -> float:
    """Restitution of an elastic-perfectly plastic Hertz contact at ``speed`` (m/s) with yield
    speed ``v_yield`` (m/s; None: elastic): 1 up to it, above Thornton's closed form (J. Appl.
    Mech. 64 (1997) 383; docs/physics.md, "Yield of the contact"), falling as ``v^(-1/4)``."""
    v = checks.positive("speed", speed, "m/s")
    if v_yield is None:
        return 1.0
    v_y = checks.positive("v_yield", v_yield, "m/s")
    if v <= v_y:
        return 1.0
    r = v_y / v
    shape = math.sqrt(6.0 * math.sqrt(3.0) / 5.0) * math.sqrt(1.0 - r * r / 6.0)
    return shape * (r / (r + 2.0 * math.sqrt(6.0 / 5.0 - r * r / 5.0))) ** 0.25


def yield_penetration(ball: Ball, plate: Plate, stiffness: float) -> float:
    """Penetration ``delta_y = R (pi p_y / (2 E*))^2`` (m) at which the Hertz peak pressure of
    ``stiffness`` (N/m^1.5) reaches :func:`yield_pressure` (Thornton 1997); inf without one."""
    p_y = yield_pressure(ball, plate)
    if p_y is None:
        return math.inf
    R = ball.radius
    e_star = 0.75 * stiffness / math.sqrt(R)
    return R * (math.pi * p_y / (2.0 * e_star)) ** 2


def model_yield_speed(ball: Ball, plate: Plate, law: str | None, surface: str) -> float | None:
    """Yield speed (m/s) under ``law`` and ``surface``, ``1/2 m V_y^2 = (2/5) K delta_y^(5/2)``;
    only the measured surfaces of the Hertz law carry a yield, else None."""
    checks.choice("surface", surface, SURFACE_MODELS)
    if isinstance(ball, HollowBall) or surface == "ideal":
        return None
    if (own_law(ball) if law is None else law) != "hertz":
        return None
    c = contact_parameters(ball, plate, "hertz", surface=surface)
    if c.yield_penetration == math.inf:
        return None
    return math.sqrt(0.8 * c.stiffness * c.yield_penetration**2.5 / ball.mass)


def yield_rebound(ball: Ball, plate: Plate):
    """A rebound rule: the solver's restitution times Thornton's at the pair's :func:`yield_speed`
    (losses independent; the pulse stays elastic), for a surface whose law carries no yield."""
    v_yield = yield_speed(ball, plate)

    def rebound(result, speed: float) -> float:
        return result.restitution * plastic_restitution(speed, v_yield)

    return rebound
