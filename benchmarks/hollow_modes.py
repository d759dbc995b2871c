"""The hollow balls' contact with the wall's lowest modes as dynamic degrees of freedom.

A diagnosis beside ``synth bench hollow`` (docs/validation.md, "Hollow balls"), not the
engine's bounce: the rule-book drops of :mod:`benchmarks.hollow` integrated with the shell's
lowest axisymmetric modes (orders ``1..N``, both branches of Hayek's equation, the ``n = 1``
translation left out) taking part in the contact, as the plate's modes do in the modal contact.

The split (a static correction, as the mode-acceleration method's): the shell law keeps the
ball's whole quasi-static compliance, so the modes' static compliance at the pole,
``C_m = sum 1 / k_j``, is taken off the law's: the law's deflection ``delta`` and the
residual ``d = delta(F) - C_m F`` (a closed form on both branches of the law), and the
approach of the ball's centre ``x = d + sum y_j``, ``y_j`` the modes' displacements at the
pole (positive inward). Each mode is an oscillator of the pole's effective mass ``mu_j = m_s /
((2 n + 1) s_j)`` (``m_s`` the shell's mass, ``s_j`` the mode's radial share, the radial
motion ``P_n(cos theta)``, whose mean square over the sphere is ``1 / (2 n + 1)``):

    mu_j y_j'' + c_j y_j' + mu_j omega_j^2 y_j = F,

the loss ``c_j`` on the wall's elastic part ``k_e`` of the mode's stiffness (the prestress'
part is the gas', lossless): the law's Kelvin-Voigt time, ``c_j = A k_e`` (``A = eta /
omega_c``, the material's loss factor ``eta`` at the contact's frequency, as the law takes
it), or at the mode's own frequency, ``c_j = eta k_e / omega_j`` (the hysteretic loss as the
viscous one of equal loss at resonance, ``2 zeta = eta``: L. Cremer, M. Heckl & B. A. T.
Petersson, "Structure-Borne Sound", 3rd ed. (Springer 2005), section 2.5). The ball ``m w' =
m g - F``, the plate's admittance ``beta`` as the engine's (``x' = w - beta F``), and the
law's own loss, its Kelvin-Voigt term, on the residual: ``F = F_r(d) + A k_d d'`` (clipped at
0; :class:`ResidualLaw`). Without modes this is the engine's shell contact. The modes'
frequencies carry the gauge pressure's prestress (:func:`prestressed_mode_frequencies`).
Whatever energy the modes hold when the force ends is lost to the rebound (the wall rings
down).

The static correction needs ``C_m < 1 / k0`` (``k0`` the law's small-deflection stiffness):
a ball whose retained modes are more compliant at the pole than the whole law cannot be
split this way (:attr:`WallModes.admissible`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from synth.constants import GRAVITY
from synth.errors import ParameterError


def prestress_stiffness(ball, n: int) -> float:
    """The gauge pressure's prestress as a radial stiffness of the order-``n`` modes, in the
    units of Hayek's equation (dimensionless, of ``(1 - nu^2) R^2 / (E h)`` per area): the
    wall's membrane tension ``N = p R / 2`` (Laplace's law of a thin sphere, ``p`` the gauge
    pressure, ``R`` the mid-surface radius) resists the radial shape ``W P_n`` with ``N (n -
    1) (n + 2) / R^2`` per unit area, as a drop's surface tension does (Lord Rayleigh, "On the
    capillary phenomena of jets", Proc. R. Soc. Lond. 29 (1879) 71; H. Lamb, "Hydrodynamics",
    6th ed. (1932), section 275): ``g = p R (b - 2) (1 - nu^2) / (2 E h)``, ``b = n (n + 1)``.
    It is 0 for ``n = 1`` (a translation) and for an unpressurised ball."""
    mat = ball.material
    h = ball.thickness
    radius = ball.shell_radius - 0.5 * h
    b = n * (n + 1.0)
    return ball.pressure * radius * (b - 2.0) * (1.0 - mat.poisson**2) / (2.0 * mat.young * h)


def _tangential_entry(ball, n: int) -> float:
    """The tangential equation's diagonal stiffness ``b - (1 - nu)`` of the membrane sphere
    (:func:`benchmarks.hollow.radial_share`'s first equation; its bending part, of order
    ``h^2 / (12 R^2)``, left out)."""
    return n * (n + 1.0) - (1.0 - ball.material.poisson)


def prestressed_mode_frequencies(ball, n: int) -> tuple[float, ...]:
    """The angular frequencies (rad/s, ascending) of ``ball``'s axisymmetric shell modes of
    order ``n`` with the gauge pressure's prestress: Hayek's equation ``L^2 - P L + Q = 0``
    (:func:`benchmarks.hollow.shell_mode_frequencies`) is the determinant ``(A - L)(D - L) -
    B C`` of the tangential and radial equations; the prestress adds ``g``
    (:func:`prestress_stiffness`) to the radial ``D``, which adds ``g (A - L)`` to it, ``A``
    the tangential entry: ``L^2 - (P + g) L + Q + g A = 0``. At zero pressure these are
    Hayek's. ``n = 1``'s translation (0) is left out."""
    from benchmarks.hollow import hayek_coefficients

    p, q, scale = hayek_coefficients(ball, n)
    g = prestress_stiffness(ball, n)
    p, q = p + g, q + g * _tangential_entry(ball, n)
    root = math.sqrt(p * p - 4.0 * q)
    roots = [0.5 * (p - root), 0.5 * (p + root)]
    return tuple(scale * math.sqrt(L) for L in roots if L > 1e-9 * p)


def prestressed_radial_share(ball, n: int, omega: float) -> float:
    """The radial share (dimensionless) of the kinetic energy of the order-``n`` mode at
    ``omega`` (rad/s): ``1 / (1 + b (U / W)^2)`` as :func:`benchmarks.hollow.radial_share`,
    ``U / W = -(1 + nu) / (A - L)`` from the tangential equation, which the prestress leaves
    as it is (``L = rho (1 - nu^2) R^2 omega^2 / E``)."""
    mat = ball.material
    radius = ball.shell_radius - 0.5 * ball.thickness
    b = n * (n + 1.0)
    L = mat.density * (1.0 - mat.poisson**2) * radius**2 * omega**2 / mat.young
    ratio = (1.0 + mat.poisson) / (_tangential_entry(ball, n) - L)
    return 1.0 / (1.0 + b * ratio * ratio)


@dataclass(frozen=True)
class WallModes:
    """The shell modes a contact integrates: their orders, angular frequencies (rad/s), the
    pole's effective masses (kg) and the wall's elastic part of their stiffness at the pole
    (N/m: ``mu omega^2`` less the prestress', :func:`prestress_pole_stiffness`, on which the
    material's loss acts); the law's small-deflection stiffness ``k0`` (N/m)."""

    order: tuple[int, ...]
    omega: tuple[float, ...]
    mass: tuple[float, ...]
    elastic: tuple[float, ...]
    k0: float

    @property
    def compliance(self) -> float:
        """``C_m = sum 1 / (mu_j omega_j^2)``, m/N: the modes' static compliance at the pole."""
        return float(sum(1.0 / (m * w * w) for m, w in zip(self.mass, self.omega, strict=True)))

    @property
    def admissible(self) -> bool:
        """Whether the law's compliance holds the modes': ``C_m k0 < 1``."""
        return self.compliance * self.k0 < 1.0


def wall_modes(ball, max_order: int, prestressed: bool = True) -> WallModes:
    """``ball``'s axisymmetric shell modes of orders 1 to ``max_order`` (both branches),
    with (``prestressed``) or without the gauge pressure's prestress."""
    from benchmarks.hollow import radial_share, shell_mode_frequencies
    from synth.physics.contact_law import shell_law

    order, omega, mass, elastic = [], [], [], []
    for n in range(1, max_order + 1):
        if prestressed:
            modes = [(w, prestressed_radial_share(ball, n, w))
                     for w in prestressed_mode_frequencies(ball, n)]  # fmt: skip
        else:
            modes = [(w, radial_share(ball, n, w)) for w in shell_mode_frequencies(ball, n)]
        for w, share in modes:
            order.append(n)
            omega.append(w)
            mass.append(ball.shell_mass / ((2.0 * n + 1.0) * share))
            stress = prestress_pole_stiffness(ball, n) if prestressed else 0.0
            elastic.append(mass[-1] * w * w - stress)
    law = shell_law(ball)
    return WallModes(tuple(order), tuple(omega), tuple(mass), tuple(elastic), law.stiffness)


def prestress_pole_stiffness(ball, n: int) -> float:
    """The prestress' part of an order-``n`` mode's stiffness at the pole, N/m: the
    geometric stiffness ``N (b - 2) / R^2`` per area (:func:`prestress_stiffness`) over the
    radial shape's mean square ``1 / (2 n + 1)``, with the shell's area ``4 pi R^2``:
    ``2 pi R p (b - 2) / (2 n + 1) = k_g (n - 1)(n + 2) / (2 n + 1)``, ``k_g = 2 pi R p`` the
    shell law's gas stiffness (R the mid-surface radius here). Summed over the orders it
    grows as ``2 ln(n) / k_g`` in compliance: a point load on a membrane, which the finite
    contact disc of the law cuts off."""
    radius = ball.shell_radius - 0.5 * ball.thickness
    b = n * (n + 1.0)
    return 2.0 * math.pi * radius * ball.pressure * (b - 2.0) / (2.0 * n + 1.0)


@dataclass(frozen=True)
class ResidualLaw:
    """The shell law less the modes' static compliance ``C_m`` (m/N): its force ``F_r`` (N) and
    the stiffness its Kelvin-Voigt term takes (N/m) at the residual deflection ``d`` (m).
    Below the transition ``F = k0 delta``, so ``d = (1 / k0 - C_m) F``; beyond it ``F = k_R
    sqrt(delta_t) s + k_g s^2`` with ``s = sqrt(delta)``, so ``d = (1 - C_m k_g) s^2 - C_m k_R
    sqrt(delta_t) s``, a quadratic in ``s``. The law's loss ``A k_s`` acts on the shell's
    tangent ``k_s`` (the gas is lossless); the residual's, on the same share ``k_s / k_t`` of
    its own tangent ``k_r = 1 / (1 / k_t - C_m)`` (``k_t`` the law's tangent): in series with
    modes of the same Kelvin-Voigt time the law's loss is kept quasi-statically."""

    reissner: float
    gas: float
    transition: float
    compliance: float

    def force(self, d: float) -> tuple[float, float]:
        """``(F_r, k_s k_r / k_t)`` at ``d`` (0 force for ``d <= 0``)."""
        k0 = self.reissner + self.gas
        if d <= 0.0:
            return 0.0, self.reissner / (1.0 - self.compliance * k0)
        if d < self.transition * (1.0 - self.compliance * k0):
            return d / (1.0 / k0 - self.compliance), self.reissner / (1.0 - self.compliance * k0)
        root_t = math.sqrt(self.transition)
        c = self.compliance * self.reissner * root_t
        a = 1.0 - self.compliance * self.gas
        s = (c + math.sqrt(c * c + 4.0 * a * d)) / (2.0 * a)
        shell = 0.5 * self.reissner * root_t / s
        residual_over_law = 1.0 / (1.0 - self.compliance * (shell + self.gas))
        return self.reissner * root_t * s + self.gas * s * s, shell * residual_over_law


@dataclass(frozen=True)
class ModalBounce:
    """One impact with the wall's modes: the rebound speed (m/s, from ``speed``), and the
    shares of the impact energy ``m v^2 / 2`` (dimensionless) the law's Kelvin-Voigt loss,
    the modes' loss, the plate and the modes' energy after separation (``ringing``) take;
    ``balance`` the energy not accounted for (kinetic in plus gravity's work minus kinetic
    out and the four, over the impact energy: the integration's error); ``end_time`` (s) when the contact was found over (the gap beyond the
    modes' reach)."""

    speed: float
    rebound_speed: float
    law_loss: float
    mode_loss: float
    plate_loss: float
    ringing: float
    balance: float
    end_time: float

    @property
    def restitution(self) -> float:
        """The rebound speed over the impact speed (dimensionless)."""
        return self.rebound_speed / self.speed


def modal_bounce(
    ball, surface, speed: float, modes: WallModes, resonant: bool = False, rtol: float = 1e-10
) -> ModalBounce:
    """``ball`` onto ``surface`` (a :class:`~synth.physics.scene.Plate`, its infinite plate's
    admittance) at ``speed`` (m/s) with ``modes`` in the contact (module docstring), under
    :data:`~synth.constants.GRAVITY`, integrated by DOP853 (scipy) to ``rtol``. The modes'
    loss acts on the wall's elastic stiffness ``k_e`` with the law's Kelvin-Voigt time ``A``
    (``c = A k_e``: the material's loss factor at the contact's frequency, as the law's), or
    with ``resonant`` at each mode's own frequency (``c = eta k_e / omega``). The pole may
    leave the plate and touch it again while the ball is still coming in: the contact ends
    once the ball moves away with its gap larger than the modes' amplitudes can close."""
    from synth.physics.contact_law import shell_law
    from synth.physics.impedance import infinite_plate_impedance

    if not modes.admissible:
        raise ParameterError(
            f"modes={modes!r}: their static compliance at the pole is "
            f"{modes.compliance * modes.k0:g} times the shell law's; the split needs less than 1"
        )
    law = shell_law(ball)
    residual = ResidualLaw(law.reissner_stiffness, law.gas_stiffness, law.transition,
                           modes.compliance)  # fmt: skip
    m, beta, A = ball.mass, 1.0 / infinite_plate_impedance(surface), law.viscous_time
    mu, om, ke = (np.array(v) for v in (modes.mass, modes.omega, modes.elastic))
    c = ke * (ball.material.damping.eta / om if resonant else A)
    k = len(mu)

    def rhs(_, z):
        d, w, y, u = z[0], z[3], z[4 : 4 + k], z[4 + k : 4 + 2 * k]
        fr, ks = residual.force(d)
        f = 0.0 if d <= 0.0 else max((fr + A * ks * (w - u.sum())) / (1.0 + A * ks * beta), 0.0)
        dd = w - beta * f - u.sum()
        du = (f - c * u - mu * om * om * y) / mu
        losses = [(f - fr) * dd if d > 0.0 else 0.0, float(np.sum(c * u * u)), beta * f * f]
        return np.concatenate(([dd, w - beta * f, w, GRAVITY - f / m], u, du, losses))

    def gone(_, z):
        # x plus the modes' largest reach (their energy's amplitude) below 0, moving away
        y, u = z[4 : 4 + k], z[4 + k : 4 + 2 * k]
        reach = np.sum(np.sqrt(y * y + (u / om) ** 2))
        return z[1] + reach if z[3] < 0.0 else 1.0

    gone.terminal, gone.direction = True, -1.0
    z0 = np.zeros(7 + 2 * k)
    z0[3] = speed
    period = 2.0 * math.pi * math.sqrt(m / law.stiffness)
    sol = solve_ivp(rhs, (0.0, 20.0 * period), z0, method="DOP853", rtol=rtol,
                    atol=rtol * 1e-6 * max(speed, 1.0) * period,
                    events=gone, first_step=1e-6 * period)  # fmt: skip
    if sol.status != 1:
        raise RuntimeError(f"the modal contact did not end within 20 periods: {sol.message}")
    return _bounce(ball, speed, sol.y[:, -1], mu, om, float(sol.t[-1]))


def _bounce(ball, speed, z, mu, om, t_end) -> ModalBounce:
    """The :class:`ModalBounce` of the end state ``z`` (``d, x, X, w``, the modes, the losses):
    the rebound speed where the ball left the plate's surface, as the engine's (gravity's
    deceleration over its rise ``-x`` above it undone), and the energy balance (gravity's work
    on the ball's own displacement ``X``)."""
    m, k = ball.mass, len(mu)
    x, ball_x, w = z[1], z[2], z[3]
    y, u = z[4 : 4 + k], z[4 + k : 4 + 2 * k]
    energy = 0.5 * m * speed * speed
    ringing = float(np.sum(0.5 * mu * (u * u + om * om * y * y)))
    law_loss, mode_loss, plate_loss = z[4 + 2 * k :]
    kinetic = 0.5 * m * w * w
    leftover = energy + m * GRAVITY * ball_x - kinetic - law_loss - mode_loss - plate_loss
    rebound = math.sqrt(w * w - 2.0 * GRAVITY * x)
    return ModalBounce(
        speed, rebound, law_loss / energy, mode_loss / energy, plate_loss / energy,
        ringing / energy, (leftover - ringing) / energy, t_end,
    )  # fmt: skip


#: The highest orders of the modes :func:`modes_note` takes into the contact (dimensionless).
NOTE_ORDERS = (2, 3, 4)


def modes_note(test) -> str:
    """A line of docs/validation.md: ``test``'s drop through the air (as
    :func:`benchmarks.hollow.rule_book_row`'s) with the wall's modes of orders 1 to each of
    :data:`NOTE_ORDERS` in the contact (:func:`modal_bounce`, prestressed, the law's loss)."""
    from benchmarks.hollow import fall_speed, rise_height, terminal_speed
    from synth.io.presets import load_preset

    ball = load_preset(test.preset).ball
    v_t = terminal_speed(ball.mass, ball.radius, test.drag_coefficient)
    speed = fall_speed(test.drop, v_t)
    top = 2.0 * ball.radius if test.to_top else 0.0
    parts = []
    for n in NOTE_ORDERS:
        modes = wall_modes(ball, n)
        if not modes.admissible:
            parts.append(
                f"orders 1-{n}: the modes' static compliance at the pole is "
                f"{modes.compliance * modes.k0:.2f} times the law's, beyond the split"
            )
            continue
        b = modal_bounce(ball, test.surface, speed, modes)
        r = modal_bounce(ball, test.surface, speed, modes, resonant=True)
        parts.append(
            f"orders 1-{n} ({modes.compliance * modes.k0:.2f} of the law's compliance): "
            f"rebound {rise_height(b.rebound_speed, v_t) + top:.3f} m, e {b.restitution:.3f}, "
            f"the modes' loss {b.mode_loss:.1e} and ringing {b.ringing:.1e} of the impact "
            f"energy ({rise_height(r.rebound_speed, v_t) + top:.3f} m with the modes' loss "
            f"factor at their own frequencies)"
        )
    return (
        f"- {test.ball}, with the wall's lowest modes in the contact (prestressed by the gauge "
        f"pressure, their static compliance taken off the law's, their loss the law's "
        f"Kelvin-Voigt time; `benchmarks/hollow_modes.py`, a diagnosis, not the engine's "
        f"bounce): " + "; ".join(parts) + "."
    )
