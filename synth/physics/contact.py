"""One impact: a ball against a plate's local contact stiffness and its mechanical impedance.

The model of docs/physics.md, "Hertz contact" (the thesis, docs/physics.md, References,
eqs. 2.9-2.11, 2.34, 2.42):

    d(delta)/dt = v_plate - v_s,    v_plate = v_free - beta F(delta)
    d(v_s)/dt   = F / m - g
    F = K delta^n                   (Hertz: n = 3/2, K = 4/3 sqrt(R) E*)
    F = K delta^n (1 + mu d(delta)/dt),  F >= 0     (Hunt-Crossley)
    F = K (delta^(3/2) + (3/2) A delta^(1/2) d(delta)/dt),  F >= 0     (viscoelastic Hertz)

``solve_contact`` takes the lumped parameters; ``solve_impact`` derives them from
a :class:`~synth.physics.scene.Ball` and a :class:`~synth.physics.scene.Plate` and a named law
(:func:`contact_parameters`; the viscoelastic one: Kuwabara & Kono 1987, Brilliantov et al.
1996, docs/physics.md, "Contact losses"). Both return an
:class:`ImpactResult`. Numerical trouble is reported in ``success``, ``status``
and ``message``; only bad input raises (``ParameterError``).

Numerics (see ``synth/physics/contact_kernels/``): the equations are scaled by
Zener's time ``theta = (m / (K v0^(n-1)))^(1/(n+1))`` and length ``theta v0``, so
every state variable is of order one and one relative tolerance means the same
for every ball and plate; they are integrated by DOP853 where the contact is not
stiff and by Radau IIA (order 5) where it is (Zener's inelasticity
``lam = beta m / theta`` above :data:`STIFF_LAMBDA`). The end of contact is
located on the dense output to machine precision.

Error control: the integrators' local tolerance is ``rtol *``
:data:`TOLERANCE_SAFETY`, a proportionality factor chosen once from the
benchmark ``synth bench contact`` so that the measured global relative errors of
the restitution and the contact time stay below the ``rtol`` asked for over the
benchmark's cases and tolerances (1e-3 to 1e-10). For very small restitution
(``e`` below about ``rtol``) the error bound is absolute, ``rtol``, not relative.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np

from synth import checks
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics import contact_kernels as _k
from synth.physics import impedance
from synth.physics.contact_kernels import shell as _shell
from synth.physics.contact_law import ShellLaw, contact_parameters
from synth.physics.scene import Ball, Plate

#: Zener's inelasticity above which the contact is integrated by the implicit Radau IIA
#: method; the absolute tolerance relative to the local one; the step limits of DOP853
#: and of the implicit method (constants of the compiled kernel, see contact_kernels).
STIFF_LAMBDA = _k.STIFF_LAMBDA
ABSOLUTE_FACTOR = _k.ABSOLUTE_FACTOR
EXPLICIT_STEP_LIMIT = _k.EXPLICIT_STEP_LIMIT
IMPLICIT_STEP_LIMIT = _k.IMPLICIT_STEP_LIMIT
#: Local tolerance of the integrators relative to the requested ``rtol``.
TOLERANCE_SAFETY = 0.2
#: Fewest samples of a force pulse over the contact.
MIN_POINTS = 64

_MESSAGES = {
    _k.SEPARATED: "The ball separated from the plate.",
    _k.SETTLED: "The ball settled: its energy fell below what a separation needs.",
    _k.MAX_STEPS: "The step limit was reached before the contact ended.",
    _k.STEP_TOO_SMALL: "The step size fell below the resolution of the time axis.",
}
_TINY_REBOUND = (
    "The ball separated with a rebound speed below the solver's resolution; "
    "restitution reported as 0."
)
#: Status of a contact integrated to its end whose energy balance is not met.
ENERGY_IMBALANCE = -3
#: Largest energy residual (relative, see ``ImpactResult.energy_residual``) of a result
#: reported as a success: the solver meets its tolerance with residuals of 1e-7 and
#: below; 1 % means the integration lost the physics (e.g. an admittance so large
#: that the contact lasts less than the time axis resolves).
ENERGY_RESIDUAL_LIMIT = 0.01


def _energy_message(residual: float) -> str:
    return (
        f"The energy balance is not met: residual {residual:.3g} of the energy "
        f"exchanged (at most {ENERGY_RESIDUAL_LIMIT:g}); the result is not physical."
    )


_METHODS = {"auto": _k.AUTO, "DOP853": _k.DOP853, "Radau": _k.RADAU}
_INF = math.inf


class DenseOutput(NamedTuple):
    """The solver's dense output of one contact, for sampling the pulse afterwards:
    the step history of the kernels, the integrator (``radau``), the dimensionless
    parameters (``lam``, ``G``, ``n``, the losses ``c`` and ``b``, end of contact
    ``s_contact``) and the
    scales back to SI units (``theta``, s; ``f_scale``, N)."""

    hist: np.ndarray
    radau: bool
    lam: float
    G: float
    n: float
    c: float
    b: float
    s_contact: float
    theta: float
    f_scale: float
    n_points: int


@dataclass(frozen=True, eq=False)
class ImpactResult:
    """The outcome of one impact (SI units).

    Attributes
    ----------
    restitution : float
        ``e = v_out / v_in``, dimensionless; 0 when the ball settled.
    contact_time : float
        Duration of the contact ``tau``, s: the force pulse's length (the force > 0), the
        quantity a force transducer measures and the thesis reports (docs/validation.md).
        For a settled ball: the time at which the ball was proven unable to separate.
    separation_time : float
        Time from first touch to separation, s: the penetration's return to 0, where the
        ball's free flight starts (the bounce scheduler's clock). Equal to ``contact_time``
        for an elastic law; with a loss the force falls to 0 first, while the ball still
        moves apart from the indented surface (about ``(3/2) A`` later with the
        viscoelastic loss, docs/physics.md, "Contact losses"). For a settled ball: as
        ``contact_time``.
    max_penetration : float
        Largest local deformation ``delta_max``, m.
    peak_force : float
        Largest contact force, N.
    impulse : float
        Integral of the contact force over the contact, N s.
    inelasticity : float
        Zener's parameter ``lam = beta m / theta``, dimensionless.
    settled : bool
        True if the ball never separated (it came to rest on the plate).
    rebound_speed : float
        Relative speed of separation ``v_out = v_s(tau) - v_free``, m/s (0 if settled).
    plate_energy : float
        Energy carried into the plate, ``beta * Int(F^2 dt)``, J.
    time : ndarray
        Times of the pulse samples from first touch to separation, s (uniform,
        ``n_points``); sampled from the dense output on first access, like ``force``.
    force : ndarray
        Contact force at those times, N.
    energy_residual : float
        Error of the energy balance (docs/physics.md, "Hertz contact"; with the
        contact's loss), relative to the energy exchanged: the impact's kinetic energy, or
        the work of gravity or the energy carried into the plate where larger.
    success : bool
        True if the contact was integrated to its end.
    status : int
        0 separated, 1 settled, negative: failure (see ``message``; -3: the energy
        balance is off by more than ``ENERGY_RESIDUAL_LIMIT``).
    message : str
        Human-readable description of ``status``.
    n_steps : int
        Accepted integration steps (after the series start of the contact).
    method : str
        ``"DOP853"`` or ``"Radau"``; ``"DOPRI5"`` for a hollow ball's thin-shell law
        (:class:`ShellImpactResult`).
    """

    restitution: float
    contact_time: float
    separation_time: float
    max_penetration: float
    peak_force: float
    impulse: float
    inelasticity: float
    settled: bool
    rebound_speed: float
    plate_energy: float
    energy_residual: float
    success: bool
    status: int
    message: str
    n_steps: int
    method: str

    _dense: DenseOutput | None = field(default=None, repr=False, compare=False)

    @cached_property
    def time(self) -> np.ndarray:
        return self._sample_pulse()[0]

    @cached_property
    def force(self) -> np.ndarray:
        return self._sample_pulse()[1]

    @property
    def exponent(self) -> float:
        """Exponent ``n`` of the contact law ``F = K delta^n`` (dimensionless): the pulse
        rises like ``t^n`` after first touch and falls like ``(tau - t)^n`` before
        separation."""
        return self._dense.n

    @property
    def pulse_order(self) -> float:
        """Exponent ``q`` of the trapezoid rule's leading error ``C h^q`` on the force pulse
        (dimensionless; the modal bank extrapolates with it): ``n + 1`` for a pulse that rises
        like ``t^n`` and falls like ``(tau - t)^n``; ``3/2`` with the viscoelastic loss, whose
        force rises like ``t^(1/2)`` (and switches off with a kink before separation: ``h^2``)."""
        d = self._dense
        if d is not None and d.b != 0.0:
            return 1.5
        return self.exponent + 1.0

    def _sample_pulse(self):
        # Both arrays at once, cached beside each other (most uses of an impact, such as
        # rendering, need only force_at).
        d = self._dense
        times = np.empty(d.n_points)
        forces = np.empty(d.n_points)
        _k.pulse(
            d.hist,
            d.radau,
            d.lam,
            d.G,
            d.n,
            d.c,
            d.b,
            d.s_contact,
            self.status == _k.SEPARATED,
            d.theta,
            d.f_scale,
            times,
            forces,
        )
        self.__dict__.update(time=times, force=forces)
        return times, forces

    def force_at(self, t) -> float | np.ndarray:
        """Contact force (N) at times ``t`` (s from first touch, array-like), evaluated on the
        solver's dense output (its accuracy is the solver's); 0 outside the contact."""
        out, _ = self.force_and_slope_at(np.atleast_1d(t))
        return out.reshape(np.shape(t)) if np.ndim(t) else float(out[0])

    def pulse_samples(
        self, step: float, points: int, offset: float, period: float, samples: int, out=None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Force (N) and its rate of change (N/s) on a uniform grid ``j step`` (s, ``j <
        points``) and then at ``offset + m period`` (s, ``m < samples``), times from first
        touch: :meth:`force_and_slope_at` of those times, in one call (the modal bank's
        pulse grid and in-contact audio samples). ``out``: an optional (2, L) float array,
        ``L >= points + samples``, whose rows take the forces and the slopes (the live
        engine writes them straight into a slot); returns views of its rows then."""
        points, samples = int(points), int(samples)
        total = points + samples
        if out is None:
            out = np.empty((2, total))
        elif out.ndim != 2 or out.shape[0] != 2 or out.shape[1] < total:
            raise ParameterError(
                f"out has shape {out.shape}; the pulse samples need (2, >= {total})"
            )
        self._pulse_force_slope(float(step), points, float(offset), float(period), samples, out)
        return out[0, :total], out[1, :total]

    def _pulse_force_slope(self, step, points, offset, period, samples, out) -> None:
        """:meth:`pulse_samples`' forces and slopes into ``out``'s rows, in one compiled
        call on the Hertz-family dense output."""
        d = self._dense
        _k.pulse_force_slope(
            d.hist, d.radau, d.lam, d.G, d.n, d.c, d.b, d.s_contact, d.theta, d.f_scale,
            step, points, offset, period, samples, out,
        )  # fmt: skip

    def force_and_slope_at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Contact force (N) and its rate of change (N/s) at times ``t`` (s from first
        touch, a 1-D array), from the solver's dense output; both 0 outside the contact."""
        s = np.ascontiguousarray(np.asarray(t, dtype=float).ravel() / self._dense.theta)
        out = np.empty_like(s)
        slope = np.empty_like(s)
        self._force_and_slope(s, out, slope)
        return out, slope

    def _force_and_slope(self, s, out, slope) -> None:
        """Force (N) into ``out`` and its rate (N/s) into ``slope`` at the dimensionless
        times ``s`` (s / theta): the dense output's, scaled to SI units."""
        d = self._dense
        _k.force_slope_at(d.hist, d.radau, d.lam, d.G, d.n, d.c, d.b, d.s_contact, s, out, slope)
        out *= d.f_scale
        slope *= d.f_scale / d.theta


class ShellDense(NamedTuple):
    """The dense output of a thin-shell contact (:mod:`.contact_kernels.shell`): its
    history, the dimensionless parameters (``lam``, ``G``, ``r_R``, ``x_t``, ``r_g``, ``a``,
    end of contact ``s_contact``) and the scales (``theta``, s; ``f_scale``, N)."""

    hist: np.ndarray
    lam: float
    G: float
    rR: float
    xt: float
    rg: float
    a: float
    s_contact: float
    theta: float
    f_scale: float
    n_points: int


class ShellImpactResult(ImpactResult):
    """An :class:`ImpactResult` of the thin-shell law (a
    :class:`~synth.physics.scene.HollowBall`): the same fields, its pulse from the shell
    kernel's dense output."""

    @property
    def exponent(self) -> float:
        """1: the shell law is linear at first touch (Reissner's stiffness and the gas')."""
        return 1.0

    @property
    def pulse_order(self) -> float:
        """``q`` of the trapezoid rule's error ``C h^q`` on the pulse: 2 for the lossless
        shell (the force rises like ``t``), 1 with the Kelvin-Voigt loss (the force starts
        with a step ``A k_R v``)."""
        return 1.0 if self._dense.a != 0.0 else 2.0

    def _sample_pulse(self):
        d = self._dense
        s = np.linspace(0.0, d.s_contact, d.n_points)
        forces = np.empty(d.n_points)
        slopes = np.empty(d.n_points)
        _shell.shell_force_slope(
            d.hist, d.lam, d.G, d.rR, d.xt, d.rg, d.a, d.s_contact, s, forces, slopes
        )
        if self.status != _k.SEPARATED:
            forces[-1] = _shell_force_at_end(d)
        times = s * d.theta
        forces *= d.f_scale
        self.__dict__.update(time=times, force=forces)
        return times, forces

    def _pulse_force_slope(self, step, points, offset, period, samples, out) -> None:
        """:meth:`pulse_samples`' forces and slopes into ``out``'s rows, from the shell
        kernel's dense output at the grid's times."""
        total = points + samples
        s = np.empty(total)
        s[:points] = np.arange(points) * step
        s[points:] = offset + np.arange(samples) * period
        s /= self._dense.theta
        self._force_and_slope(s, out[0, :total], out[1, :total])

    def _force_and_slope(self, s, out, slope) -> None:
        d = self._dense
        _shell.shell_force_slope(
            d.hist, d.lam, d.G, d.rR, d.xt, d.rg, d.a, d.s_contact, s, out, slope
        )
        out *= d.f_scale
        slope *= d.f_scale / d.theta


def _shell_force_at_end(d: ShellDense) -> float:
    """The dimensionless force at the end of a settled contact's dense output."""
    row = d.hist[-1]
    f, _ = _shell.shell_force(row[_shell.S_X1], row[_shell.S_W1], d.lam, d.rR, d.xt, d.rg, d.a)
    return f


def _solve_shell(m, law: ShellLaw, beta, v_in, g, v_free, tol, n_points) -> ShellImpactResult:
    """One impact of the thin-shell ``law`` (checked values, SI units; docs/physics.md,
    "Hollow balls"), integrated by :func:`.contact_kernels.shell.shell_impact`."""
    k0 = law.stiffness
    rR = law.reissner_stiffness / k0
    r, hist = _shell.shell_impact(
        m, k0, rR, law.transition, 1.0 - rR, law.viscous_time, beta, v_in, g, v_free,
        tol * TOLERANCE_SAFETY,
    )  # fmt: skip
    r = r.tolist()
    status = int(r[_shell.SR_STATUS])
    residual = r[_shell.SR_ENERGY_RESIDUAL]
    energy_failed = status >= 0 and not residual <= ENERGY_RESIDUAL_LIMIT
    if energy_failed:
        status = ENERGY_IMBALANCE
    obj = object.__new__(ShellImpactResult)
    object.__setattr__(
        obj,
        "__dict__",
        {
            "restitution": r[_shell.SR_RESTITUTION],
            "contact_time": r[_shell.SR_CONTACT_TIME],
            "separation_time": r[_shell.SR_SEPARATION_TIME],
            "max_penetration": r[_shell.SR_MAX_PENETRATION],
            "peak_force": r[_shell.SR_PEAK_FORCE],
            "impulse": r[_shell.SR_IMPULSE],
            "inelasticity": r[_shell.SR_INELASTICITY],
            "settled": status == _k.SETTLED,
            "rebound_speed": r[_shell.SR_REBOUND_SPEED],
            "plate_energy": r[_shell.SR_PLATE_ENERGY],
            "energy_residual": residual,
            "success": status >= 0,
            "status": status,
            "message": (
                _energy_message(residual)
                if energy_failed
                else _TINY_REBOUND
                if r[_shell.SR_TINY_REBOUND]
                else _MESSAGES.get(status, "Unknown status.")
            ),
            "n_steps": int(r[_shell.SR_N_STEPS]),
            "method": "DOPRI5",
            "_dense": ShellDense(
                hist,
                r[_shell.SR_INELASTICITY],
                r[_shell.SR_G],
                rR,
                r[_shell.SR_XT],
                1.0 - rR,
                law.viscous_time / r[_shell.SR_THETA],
                r[_shell.SR_S_CONTACT],
                r[_shell.SR_THETA],
                r[_shell.SR_F_SCALE],
                n_points,
            ),  # fmt: skip
        },
    )
    return obj


def solve_contact(
    *,
    mass: float,
    stiffness: float,
    admittance: float,
    speed: float,
    gravity: float = GRAVITY,
    exponent: float = 1.5,
    dissipation: float = 0.0,
    viscous_time: float = 0.0,
    plate_velocity: float = 0.0,
    rtol: float = 1e-6,
    n_points: int = 128,
    method: str = "auto",
) -> ImpactResult:
    """Solve one impact from lumped parameters.

    Parameters
    ----------
    mass : float > 0
        Ball mass ``m``, kg.
    stiffness : float > 0
        Contact stiffness ``K`` of ``F = K delta^n``, N/m^n.
    admittance : float >= 0
        Plate mechanical admittance ``beta = 1/Z`` at the impact point, m/(N s).
        0 is a rigid plate.
    speed : float > 0
        Ball's impact speed ``v_in`` (downward), m/s.
    gravity : float >= 0
        Gravitational acceleration ``g``, m/s^2 (0 turns gravity off).
    exponent : float in (1, 4]
        Contact law exponent ``n`` (Hertz 1.5, elastic foundation 2).
    dissipation : float >= 0
        Hunt-Crossley damping ``mu``, s/m (0: purely elastic contact).
    viscous_time : float >= 0
        The viscoelastic Hertz contact's dissipative time ``A``, s (Hertz exponent 1.5 only;
        0: no viscoelastic loss).
    plate_velocity : float
        Velocity of the plate surface at the impact point before the impact,
        ``v_free``, m/s, positive upward; constant over the contact.
    rtol : float in [1e-12, 0.1]
        Relative accuracy asked for the restitution and the contact time.
    n_points : int >= 64
        Number of uniform samples of the force pulse over the contact.
    method : {"auto", "DOP853", "Radau"}
        Integrator; "auto" chooses by stiffness.

    Returns
    -------
    ImpactResult
    """
    # Plain floats inside their ranges (the usual call) pass at once; anything else goes
    # through the checks, which convert it or name the field, its value and the range.
    if not (
        type(mass) is float
        and type(stiffness) is float
        and type(admittance) is float
        and type(speed) is float
        and type(gravity) is float
        and type(exponent) is float
        and type(dissipation) is float
        and type(viscous_time) is float
        and type(plate_velocity) is float
        and type(rtol) is float
        and type(n_points) is int
        and 0.0 < mass < _INF
        and 0.0 < stiffness < _INF
        and 0.0 <= admittance < _INF
        and 0.0 < speed < _INF
        and 0.0 <= gravity < _INF
        and 1.0 < exponent <= 4.0
        and 0.0 <= dissipation < _INF
        and 0.0 <= viscous_time < _INF
        and (viscous_time == 0.0 or exponent == 1.5)
        and -_INF < plate_velocity < _INF
        and 1e-12 <= rtol <= 0.1
        and n_points >= MIN_POINTS
        and type(method) is str
        and method in _METHODS
    ):
        mass = checks.positive("mass", mass, "kg")
        stiffness = checks.positive("stiffness", stiffness, "N/m^n")
        admittance = checks.nonnegative("admittance", admittance, "m/(N s)")
        speed = checks.positive("speed", speed, "m/s")
        gravity = checks.nonnegative("gravity", gravity, "m/s^2")
        exponent = checks.in_range("exponent", exponent, 1.0, 4.0, "dimensionless", hi_open=False)
        dissipation = checks.nonnegative("dissipation", dissipation, "s/m")
        viscous_time = _check_viscous_time(viscous_time, exponent)
        plate_velocity = checks.real("plate_velocity", plate_velocity, "m/s")
        rtol = checks.in_range(
            "rtol", rtol, 1e-12, 0.1, "dimensionless", lo_open=False, hi_open=False
        )
        n_points = _check_points(n_points)
        checks.choice("method", method, _METHODS)
    if not speed + plate_velocity > 0.0:
        raise ParameterError(
            f"speed={speed!r} with plate_velocity={plate_velocity!r}: the approach speed "
            f"speed + plate_velocity must be > 0 (m/s) for the ball to hit the plate"
        )
    return _solve(
        mass,
        stiffness,
        admittance,
        speed,
        gravity,
        exponent,
        dissipation,
        viscous_time,
        plate_velocity,
        rtol,
        n_points,
        method,
    )


def _check_viscous_time(viscous_time, exponent: float, field: str = "viscous_time") -> float:
    """``viscous_time`` (s) as a float >= 0 that applies to ``exponent``, or
    ``ParameterError``: the viscoelastic loss is that of the Hertz law (n = 1.5)."""
    A = checks.nonnegative(field, viscous_time, "s")
    if A > 0.0 and exponent != 1.5:
        raise ParameterError(
            f"{field}={viscous_time!r} with exponent={exponent!r}: the viscoelastic loss "
            f"applies to the Hertz exponent 1.5 only"
        )
    return A


def _check_points(n_points) -> int:
    """``n_points`` as an int >= :data:`MIN_POINTS`, or ``ParameterError``."""
    if (
        isinstance(n_points, bool)
        or not isinstance(n_points, (int, np.integer))
        or n_points < MIN_POINTS
    ):
        raise ParameterError(
            f"n_points={n_points!r} must be an integer >= {MIN_POINTS} "
            f"(samples of the force pulse over the contact)"
        )
    return int(n_points)


def _solve(m, K, beta, v_in, g, n, mu, A, v_free, tol, n_points, method, shell=None):
    """``solve_contact`` on checked values (floats; ``n_points`` an int, ``method`` a name);
    with a :class:`~synth.physics.contact_law.ShellLaw` ``shell``, its thin-shell contact
    (``K, n, mu, A`` and ``method`` are then its own and unused)."""
    if shell is not None:
        return _solve_shell(m, shell, beta, v_in, g, v_free, tol, n_points)
    r, hist = _k.impact(
        m,
        K,
        beta,
        v_in,
        g,
        n,
        mu,
        A,
        v_free,
        tol * TOLERANCE_SAFETY,
        _METHODS[method],
    )
    r = r.tolist()  # Python floats, read once each
    status = int(r[_k.R_STATUS])
    stiff = bool(r[_k.R_STIFF])
    lam = r[_k.R_INELASTICITY]
    residual = r[_k.R_ENERGY_RESIDUAL]
    energy_failed = status >= 0 and not residual <= ENERGY_RESIDUAL_LIMIT
    if energy_failed:
        status = ENERGY_IMBALANCE
    obj = object.__new__(ImpactResult)
    # The solver's own values need no checks: fill the frozen instance directly (the
    # generated __init__ would take a good part of the time an impact takes).
    object.__setattr__(
        obj,
        "__dict__",
        {
            "restitution": r[_k.R_RESTITUTION],
            "contact_time": r[_k.R_CONTACT_TIME],
            "separation_time": r[_k.R_SEPARATION_TIME],
            "max_penetration": r[_k.R_MAX_PENETRATION],
            "peak_force": r[_k.R_PEAK_FORCE],
            "impulse": r[_k.R_IMPULSE],
            "inelasticity": lam,
            "settled": status == _k.SETTLED,
            "rebound_speed": r[_k.R_REBOUND_SPEED],
            "plate_energy": r[_k.R_PLATE_ENERGY],
            "energy_residual": r[_k.R_ENERGY_RESIDUAL],
            "success": status >= 0,
            "status": status,
            "message": (
                _energy_message(residual)
                if energy_failed
                else _TINY_REBOUND
                if r[_k.R_TINY_REBOUND]
                else _MESSAGES.get(status, "Unknown status.")
            ),
            "n_steps": int(r[_k.R_N_STEPS]),
            "method": "Radau" if stiff else "DOP853",
            "_dense": DenseOutput(
                hist,
                stiff,
                lam,
                r[_k.R_G],
                n,
                r[_k.R_C],
                r[_k.R_B],
                r[_k.R_S_CONTACT],
                r[_k.R_THETA],
                r[_k.R_F_SCALE],
                n_points,
            ),
        },
    )
    return obj


def solve_impact(
    ball: Ball,
    plate: Plate,
    speed: float,
    *,
    position: tuple[float, float] | None = None,
    gravity: float = GRAVITY,
    contact: str | None = None,
    rtol: float = 1e-6,
    dissipation: float | None = None,
    viscous_time: float | None = None,
    exponent: float | None = None,
    stiffness: float | None = None,
    layer_depth: float | None = None,
    surface: str = "ideal",
    plate_velocity: float = 0.0,
    n_points: int = 128,
) -> ImpactResult:
    """Solve the impact of ``ball`` on ``plate`` at ``speed``.

    Parameters
    ----------
    ball : Ball
    plate : Plate
    speed : float > 0
        Impact speed, m/s.
    position : (float, float), optional
        Impact point, metres from a plate corner. None: far from the edges (the
        infinite-plate impedance). Near an edge or corner the admittance grows
        (see :func:`synth.physics.impedance.point_admittance`); it depends on the contact
        time, so the two are solved together by fixed-point iteration.
    gravity : float >= 0
        m/s^2.
    contact : str or None
        Contact law: "hertz", "elastic-foundation", "hunt-crossley", "viscoelastic",
        "power-law" or "shell"; None: the ball's own, "shell" for a
        :class:`~synth.physics.scene.HollowBall`, else "hertz". Its parameters:
        ``dissipation``, ``viscous_time``, ``exponent``, ``stiffness``, ``layer_depth`` (see
        :func:`contact_parameters`).
    surface : {"ideal", "fitted", "auto"}
        The plate's side of the contact (see :func:`contact_parameters`; "auto": the fitted
        surface where the material has one, the measured model).
    rtol : float
        Relative accuracy of restitution and contact time.
    plate_velocity : float
        Plate surface velocity before the impact, m/s, positive upward.
    n_points : int
        Samples of the force pulse.

    Returns
    -------
    ImpactResult
    """
    if not isinstance(ball, Ball):
        raise ParameterError(f"ball={ball!r} must be a Ball")
    if not isinstance(plate, Plate):
        raise ParameterError(f"plate={plate!r} must be a Plate")
    law = contact_parameters(
        ball,
        plate,
        contact,
        dissipation=dissipation,
        viscous_time=viscous_time,
        exponent=exponent,
        stiffness=stiffness,
        layer_depth=layer_depth,
        surface=surface,
    )
    K, n, mu, A = law.stiffness, law.exponent, law.dissipation, law.viscous_time
    beta = 1.0 / impedance.infinite_plate_impedance(plate)
    if law.shell is not None:
        solver = ContactSolver(
            ball.mass, K, n, 0.0, gravity, rtol, n_points, plate, "auto", A, shell=law.shell
        )
        return solver.solve(speed, position=position, free_velocity=plate_velocity)
    kwargs = dict(
        mass=ball.mass,
        stiffness=K,
        speed=speed,
        gravity=gravity,
        exponent=n,
        dissipation=mu,
        viscous_time=A,
        plate_velocity=plate_velocity,
        rtol=rtol,
        n_points=n_points,
    )
    result = solve_contact(admittance=beta, **kwargs)
    if position is None:
        return result
    x, y = plate.check_position(position, "position")
    return _solve_at(
        plate,
        x,
        y,
        ball.mass,
        K,
        float(speed),
        float(gravity),
        n,
        mu,
        A,
        float(plate_velocity),
        float(rtol),
        int(n_points),
        first=result,
    )


#: Most contact solutions spent on the admittance near an edge (fixed point and bisection).
EDGE_ITERATIONS = 80


def _solve_at(
    plate, x, y, m, K, v_in, g, n, mu, A, v_free, tol, n_points, first=None, beta_inf=None,
    shell=None,
):  # fmt: skip
    """The impact at ``(x, y)`` (m, checked) with the position-dependent admittance of
    :func:`synth.physics.impedance.point_admittance` (lumped values checked by the caller).

    The admittance ``beta`` depends on the contact time, which depends on ``beta``:
    the pair is the root of ``r(beta) = A(tau(beta)) - beta``, with ``A`` the edge
    blend. Far from the edges (beyond the critical distance for the infinite-plate
    contact time) the first solution is already exact and is returned at once (edge
    effects are left out where they do not apply). Otherwise: fixed-point iteration
    ``beta <- A(tau(beta))``, kept inside a bracket ``[lo, hi]`` (``r(lo) >= 0 >=
    r(hi)``; initially the middle and the corner values, between which ``A`` always
    lies) and replaced by bisection when it leaves the bracket or stalls, until
    ``|r| <= rtol beta / 10`` or the bracket is that narrow. ``A(tau(beta))`` can
    jump (a contact that switches between settling and separating): then the
    bracket closes on the jump and the message says so.
    """
    if beta_inf is None:
        beta_inf = 1.0 / impedance.infinite_plate_impedance(plate)
    result = (
        first
        if first is not None
        else _solve(m, K, beta_inf, v_in, g, n, mu, A, v_free, tol, n_points, "auto", shell)
    )
    if plate.boundary != "free" or not result.success:
        return result
    if impedance.critical_distance(plate, result.contact_time) <= min(
        x, plate.length - x, y, plate.width - y
    ):
        return result
    lo = beta_inf
    hi = beta_inf / impedance.CORNER_RATIO
    settled_lo = settled_hi = False
    beta = beta_inf
    target = impedance.admittance_at(plate, x, y, result.contact_time, beta_inf)
    best = (abs(target - beta), result, beta)
    for it in range(EDGE_ITERATIONS):
        resid = target - beta
        if abs(resid) <= 0.1 * tol * beta:
            return result
        if resid > 0.0:
            lo, settled_lo = beta, result.settled
        else:
            hi, settled_hi = beta, result.settled
        if hi - lo <= 0.1 * tol * hi:
            err, res_b, beta_b = best
            if settled_lo and settled_hi:
                # e = 0 on both sides: only the landing transient depends on beta there
                why = (
                    "the ball settles on both sides, and the contact time of a settled "
                    "contact (when settling was proven) does not fix the distance at "
                    "which the edge is felt"
                )
            else:
                why = "the contact switches between settling and separating there"
            return _with_message(
                res_b,
                (
                    f"{res_b.message} The edge admittance has no consistent value: "
                    f"A(tau(beta)) jumps across beta = {beta_b:.6g} m/(N s) ({why}); the "
                    f"solution there is reported (|A - beta| = {err:.3g} m/(N s))."
                ),
            )
        # fixed-point step while it stays inside the bracket and contracts; else bisect
        beta = target if (lo < target < hi and it < 12) else 0.5 * (lo + hi)
        result = _solve(m, K, beta, v_in, g, n, mu, A, v_free, tol, n_points, "auto", shell)
        if not result.success:
            return result
        target = impedance.admittance_at(plate, x, y, result.contact_time, beta_inf)
        if abs(target - beta) < best[0]:
            best = (abs(target - beta), result, beta)
    err, res_b, beta_b = best
    return _with_message(
        res_b,
        (
            f"{res_b.message} The edge admittance did not converge in {EDGE_ITERATIONS} "
            f"contact solutions (|A - beta| = {err:.3g} m/(N s) at beta = {beta_b:.6g})."
        ),
    )


def _with_message(result, message):
    """A copy of ``result`` (an :class:`ImpactResult`, of its own class) with another
    ``message``."""
    obj = object.__new__(type(result))
    d = {k: v for k, v in result.__dict__.items() if k not in ("time", "force")}
    d["message"] = message
    object.__setattr__(obj, "__dict__", d)
    return obj


@dataclass(frozen=True, eq=False)
class ContactSolver:
    """Impacts of one ball on one plate under one contact law, at any speed.

    Built once (the contact law's parameters, the plate's impedance and every
    setting are checked and derived here) and then asked for impacts by
    :meth:`solve`: the seam through which the bounce scheduler
    (:mod:`synth.physics.bounces`) and the stimuli solve their impacts.

    Attributes
    ----------
    mass : float
        Ball mass ``m``, kg.
    stiffness : float
        Contact stiffness ``K`` of ``F = K delta^n``, N/m^n.
    exponent : float
        Contact law exponent ``n``, dimensionless.
    dissipation : float
        Hunt-Crossley damping ``mu``, s/m (0: elastic contact).
    gravity : float
        Gravitational acceleration ``g``, m/s^2.
    rtol : float
        Relative accuracy of restitution and contact time.
    n_points : int
        Samples of each force pulse.
    plate : Plate or None
        The plate, for its infinite-plate admittance and the admittance near its
        edges; None for a solver of lumped parameters (give ``admittance``).
    method : {"auto", "DOP853", "Radau"}
        Integrator.
    viscous_time : float
        The viscoelastic Hertz contact's dissipative time ``A``, s (0: none; exponent 1.5
        only).
    shell : ShellLaw or None
        The thin-shell law of a hollow ball (:func:`synth.physics.contact_law.shell_law`),
        which then sets the contact: ``stiffness`` its ``k0`` (N/m), ``exponent`` 1,
        ``viscous_time`` its shell's, ``dissipation`` 0.
    """

    mass: float
    stiffness: float
    exponent: float
    dissipation: float = 0.0
    gravity: float = GRAVITY
    rtol: float = 1e-6
    n_points: int = 128
    plate: Plate | None = None
    method: str = "auto"
    viscous_time: float = 0.0
    shell: ShellLaw | None = None

    def __post_init__(self):
        if self.shell is not None:
            self._check_shell()
            return
        checked = dict(
            mass=checks.positive("mass", self.mass, "kg"),
            stiffness=checks.positive("stiffness", self.stiffness, "N/m^n"),
            exponent=checks.in_range(
                "exponent", self.exponent, 1.0, 4.0, "dimensionless", hi_open=False
            ),
            dissipation=checks.nonnegative("dissipation", self.dissipation, "s/m"),
            gravity=checks.nonnegative("gravity", self.gravity, "m/s^2"),
            rtol=checks.in_range(
                "rtol", self.rtol, 1e-12, 0.1, "dimensionless", lo_open=False, hi_open=False
            ),
            n_points=_check_points(self.n_points),
            method=checks.choice("method", self.method, _METHODS),
        )
        checked["viscous_time"] = _check_viscous_time(self.viscous_time, checked["exponent"])
        if self.plate is not None and not isinstance(self.plate, Plate):
            raise ParameterError(f"plate={self.plate!r} must be a Plate or None")
        for key, value in checked.items():
            object.__setattr__(self, key, value)
        beta_inf = (
            None if self.plate is None else 1.0 / impedance.infinite_plate_impedance(self.plate)
        )
        object.__setattr__(self, "_beta_inf", beta_inf)

    def _check_shell(self) -> None:
        """``__post_init__`` of a thin-shell solver: its law's constants are the law's."""
        law = self.shell
        if not isinstance(law, ShellLaw):
            raise ParameterError(f"shell={law!r} must be a ShellLaw or None")
        if (self.stiffness, self.exponent, self.dissipation, self.viscous_time) != (
            law.stiffness, 1.0, 0.0, law.viscous_time,
        ):  # fmt: skip
            raise ParameterError(
                f"stiffness={self.stiffness!r}, exponent={self.exponent!r}, dissipation="
                f"{self.dissipation!r}, viscous_time={self.viscous_time!r}: with a shell law they "
                f"are its own ({law.stiffness!r}, 1.0, 0.0, {law.viscous_time!r})"
            )
        checked = dict(
            mass=checks.positive("mass", self.mass, "kg"),
            gravity=checks.nonnegative("gravity", self.gravity, "m/s^2"),
            rtol=checks.in_range(
                "rtol", self.rtol, 1e-12, 0.1, "dimensionless", lo_open=False, hi_open=False
            ),
            n_points=_check_points(self.n_points),
            method=checks.choice("method", self.method, ("auto",)),
        )
        if self.plate is not None and not isinstance(self.plate, Plate):
            raise ParameterError(f"plate={self.plate!r} must be a Plate or None")
        for key, value in checked.items():
            object.__setattr__(self, key, value)
        beta_inf = (
            None if self.plate is None else 1.0 / impedance.infinite_plate_impedance(self.plate)
        )
        object.__setattr__(self, "_beta_inf", beta_inf)

    @classmethod
    def for_pair(
        cls,
        ball,
        plate,
        *,
        gravity: float = GRAVITY,
        law: str | None = None,
        rtol: float = 1e-6,
        n_points: int = 128,
        method: str = "auto",
        **contact_options,
    ) -> ContactSolver:
        """The solver of ``ball`` on ``plate`` under the contact ``law`` (its parameters in
        ``contact_options``, see :func:`contact_parameters`; None: the ball's own law,
        "shell" for a hollow ball, else "hertz"); gravity in m/s^2."""
        if not isinstance(ball, Ball):
            raise ParameterError(f"ball={ball!r} must be a Ball")
        if not isinstance(plate, Plate):
            raise ParameterError(f"plate={plate!r} must be a Plate")
        c = contact_parameters(ball, plate, law, **contact_options)
        return cls(
            ball.mass,
            c.stiffness,
            c.exponent,
            c.dissipation,
            gravity,
            rtol,
            n_points,
            plate,
            method,
            c.viscous_time,
            c.shell,
        )

    @property
    def infinite_admittance(self) -> float | None:
        """``1 / Z_inf`` of the plate, m/(N s) (None without a plate)."""
        return self._beta_inf

    def solve(
        self,
        speed: float,
        *,
        admittance: float | None = None,
        position=None,
        free_velocity: float = 0.0,
    ) -> ImpactResult:
        """The impact at ``speed`` (m/s, downward).

        The plate's admittance at the impact point is ``admittance`` (m/(N s)) if
        given; else, with ``position`` (m from a plate corner), the position-dependent
        admittance near free edges (:func:`synth.physics.impedance.point_admittance`,
        solved together with the contact time); else the infinite plate's.
        ``free_velocity`` is the plate surface's velocity before the impact, m/s,
        positive upward.
        """
        v = (
            speed
            if type(speed) is float and 0.0 < speed < _INF
            else checks.positive("speed", speed, "m/s")
        )
        v_free = (
            free_velocity
            if type(free_velocity) is float and -_INF < free_velocity < _INF
            else checks.real("free_velocity", free_velocity, "m/s")
        )
        if not v + v_free > 0.0:
            raise ParameterError(
                f"speed={speed!r} with free_velocity={free_velocity!r}: the approach speed "
                f"speed + free_velocity must be > 0 (m/s) for the ball to hit the plate"
            )
        if admittance is not None:
            if position is not None:
                raise ParameterError("give admittance or position, not both")
            beta = checks.nonnegative("admittance", admittance, "m/(N s)")
            return _solve(
                self.mass,
                self.stiffness,
                beta,
                v,
                self.gravity,
                self.exponent,
                self.dissipation,
                self.viscous_time,
                v_free,
                self.rtol,
                self.n_points,
                self.method,
                self.shell,
            )
        if self.plate is None:
            raise ParameterError("a ContactSolver without a plate needs admittance (m/(N s))")
        if position is None:
            return _solve(
                self.mass,
                self.stiffness,
                self._beta_inf,
                v,
                self.gravity,
                self.exponent,
                self.dissipation,
                self.viscous_time,
                v_free,
                self.rtol,
                self.n_points,
                self.method,
                self.shell,
            )
        x, y = self.plate.check_position(position, "position")
        return _solve_at(
            self.plate,
            x,
            y,
            self.mass,
            self.stiffness,
            v,
            self.gravity,
            self.exponent,
            self.dissipation,
            self.viscous_time,
            v_free,
            self.rtol,
            self.n_points,
            beta_inf=self._beta_inf,
            shell=self.shell,
        )
