"""One impact: a ball against a plate's local contact stiffness and its mechanical impedance.

The model of docs/physics.md, "Hertz contact" (the thesis, eqs. 2.9-2.11, 2.34, 2.42):

    d(delta)/dt = v_plate - v_s,    v_plate = v_free - beta F(delta)
    d(v_s)/dt   = F / m - g
    F = K delta^n                   (Hertz: n = 3/2, K = 4/3 sqrt(R) E*)
    F = K delta^n (1 + mu d(delta)/dt),  F >= 0     (Hunt-Crossley)
    F = K (delta^(3/2) + (3/2) A delta^(1/2) d(delta)/dt),  F >= 0     (viscoelastic Hertz)

(the viscoelastic law: Kuwabara & Kono 1987, Brilliantov et al. 1996). ``solve_contact``
takes lumped parameters, ``solve_impact`` derives them from a Ball, a Plate and a law; both
return an :class:`ImpactResult`, numerical trouble reported in ``success``, ``status`` and
``message`` (only bad input raises ParameterError). Results are in
:mod:`~synth.physics.contact_result`, the hollow ball's solve in
:mod:`~synth.physics.contact_shell`.

Numerics (:mod:`synth.physics.contact_kernels`): the equations are scaled by Zener's time
``theta = (m / (K v0^(n-1)))^(1/(n+1))`` and length ``theta v0`` and integrated by DOP853,
or Radau IIA (order 5) where the contact is stiff (``beta m / theta`` above
:data:`STIFF_LAMBDA`); the end of contact is located on the dense output. The local
tolerance is ``rtol *`` :data:`TOLERANCE_SAFETY`, chosen with ``synth bench contact`` so the
global errors of restitution and contact time stay below ``rtol`` (absolute for ``e``
below about ``rtol``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.compilation import announce
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics import contact_kernels as _k
from synth.physics import impedance
from synth.physics.contact_law import ShellLaw, check_yield_penetration, contact_parameters
from synth.physics.contact_result import ENERGY_IMBALANCE as ENERGY_IMBALANCE
from synth.physics.contact_result import ENERGY_RESIDUAL_LIMIT as ENERGY_RESIDUAL_LIMIT
from synth.physics.contact_result import (
    DenseOutput,
    ImpactResult,
    result_from_row,
    with_message,
)
from synth.physics.contact_shell import ShellDense as ShellDense
from synth.physics.contact_shell import ShellImpactResult as ShellImpactResult
from synth.physics.contact_shell import solve_shell
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

_METHODS = {"auto": _k.AUTO, "DOP853": _k.DOP853, "Radau": _k.RADAU}
#: Most impacts of a drop solved in one compiled call (:meth:`ContactSolver.solve_drop`):
#: its result arrays grow by doubling up to that many (about 200 bytes each), the render's most.
DROP_CAPACITY = 100_000
_INF = math.inf


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


def _kernel_yield(delta_y: float, m, K, g, beta, v0: float) -> float | None:
    """The yield penetration ``delta_y`` (m) for the kernels, or None where no impact
    approached at ``v0`` (m/s) or slower can reach it
    (:func:`~synth.physics.contact_kernels.yield_reachable`): numba then runs the kernels
    compiled without the yield, the elastic law's own code."""
    if delta_y == _INF or not _k.yield_reachable(delta_y, K, m, g, beta, v0):
        return None
    return delta_y


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


def _solve(m, K, beta, v_in, g, n, mu, A, v_free, tol, n_points, method, shell=None, delta_y=_INF):
    """``solve_contact`` on checked values (floats; ``n_points`` an int, ``method`` a name);
    with a :class:`~synth.physics.contact_law.ShellLaw` ``shell``, its thin-shell contact
    (``K, n, mu, A`` and ``method`` are then its own and unused); ``delta_y``: the yield
    penetration, m (:attr:`~synth.physics.contact_law.ContactLaw.yield_penetration`)."""
    delta_y = _kernel_yield(delta_y, m, K, g, beta, v_in + v_free)
    if shell is not None:
        return solve_shell(m, shell, beta, v_in, g, v_free, tol * TOLERANCE_SAFETY, n_points)
    r, hist = _k.impact(
        m,
        K,
        beta,
        v_in,
        g,
        n,
        mu,
        A,
        delta_y,
        v_free,
        tol * TOLERANCE_SAFETY,
        _METHODS[method],
    )
    return _result(r.tolist(), hist, n, n_points)


def _result(r: list, hist, n: float, n_points: int) -> ImpactResult:
    """The :class:`ImpactResult` of a power law's contact kernel's result ``r`` (a list of
    Python floats, read once each; fields ``R_*``) and dense output ``hist``."""
    stiff = bool(r[_k.R_STIFF])
    dense = DenseOutput(
        hist,
        stiff,
        r[_k.R_INELASTICITY],
        r[_k.R_G],
        n,
        r[_k.R_C],
        r[_k.R_B],
        r[_k.R_S_CONTACT],
        r[_k.R_THETA],
        r[_k.R_F_SCALE],
        n_points,
        None if r[_k.R_XY] == _INF else r[_k.R_XY],
    )
    return result_from_row(ImpactResult, r, "Radau" if stiff else "DOP853", dense)


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
    if law.yield_penetration != _INF:
        solver = ContactSolver.for_pair(
            ball, plate, gravity=gravity, law=contact, rtol=rtol, n_points=n_points,
            surface=surface,
        )  # fmt: skip
        return solver.solve(speed, position=position, free_velocity=plate_velocity)
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
    shell=None, delta_y=_INF,
):  # fmt: skip
    """The impact at ``(x, y)`` (m, checked) with the position-dependent admittance of
    :func:`synth.physics.impedance.point_admittance`: the root of ``A(tau(beta)) = beta``
    (``A`` the edge blend, ``tau`` the contact time), at once far from the edges, else by
    fixed-point iteration kept inside a bracket and replaced by bisection when it leaves it or
    stalls, until ``|r| <= rtol beta / 10``; a jump of ``A(tau(beta))`` is reported."""
    if beta_inf is None:
        beta_inf = 1.0 / impedance.infinite_plate_impedance(plate)
    result = (
        first
        if first is not None
        else _solve(
            m, K, beta_inf, v_in, g, n, mu, A, v_free, tol, n_points, "auto", shell, delta_y
        )
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
            return with_message(
                res_b,
                (
                    f"{res_b.message} The edge admittance has no consistent value: "
                    f"A(tau(beta)) jumps across beta = {beta_b:.6g} m/(N s) ({why}); the "
                    f"solution there is reported (|A - beta| = {err:.3g} m/(N s))."
                ),
            )
        # fixed-point step while it stays inside the bracket and contracts; else bisect
        beta = target if (lo < target < hi and it < 12) else 0.5 * (lo + hi)
        result = _solve(
            m, K, beta, v_in, g, n, mu, A, v_free, tol, n_points, "auto", shell, delta_y
        )
        if not result.success:
            return result
        target = impedance.admittance_at(plate, x, y, result.contact_time, beta_inf)
        if abs(target - beta) < best[0]:
            best = (abs(target - beta), result, beta)
    err, res_b, beta_b = best
    return with_message(
        res_b,
        (
            f"{res_b.message} The edge admittance did not converge in {EDGE_ITERATIONS} "
            f"contact solutions (|A - beta| = {err:.3g} m/(N s) at beta = {beta_b:.6g})."
        ),
    )


@dataclass(frozen=True, eq=False)
class DropImpacts:
    """The impacts of a drop solved in one compiled call (:meth:`ContactSolver.solve_drop`):
    their starts (``times``, s from release), speeds (m/s) and results, and how the series
    ended (``end``: one of :data:`synth.physics.contact_kernels.BOUNCE_ENDS`;
    ``"handed-over"``: the caller goes on with the impact at ``next_time``, s from release,
    and ``next_speed``, m/s)."""

    times: tuple[float, ...]
    speeds: tuple[float, ...]
    results: tuple[ImpactResult, ...]
    end: str
    next_time: float
    next_speed: float


@dataclass(frozen=True, eq=False)
class ContactSolver:
    """Impacts of one ball on one plate under one contact law, at any speed: built once (the
    law's parameters, the plate's impedance and every setting checked and derived here), then
    asked for impacts by :meth:`solve`; the bounce scheduler and the stimuli solve through it.

    Attributes
    ----------
    mass : float
        Ball mass ``m``, kg.
    stiffness, exponent : float
        ``K`` (N/m^n) and ``n`` of ``F = K delta^n``.
    dissipation : float
        Hunt-Crossley damping ``mu``, s/m (0: elastic contact).
    viscous_time : float
        The viscoelastic Hertz contact's dissipative time ``A``, s (0: none; n = 1.5 only).
    gravity : float
        m/s^2.
    rtol : float
        Relative accuracy of restitution and contact time.
    n_points : int
        Samples of each force pulse.
    plate : Plate or None
        The plate (its admittance, also near edges); None for lumped parameters.
    method : {"auto", "DOP853", "Radau"}
        Integrator.
    shell : ShellLaw or None
        A hollow ball's thin-shell law (:func:`synth.physics.contact_law.shell_law`), which
        then sets the contact (``stiffness`` its ``k0``, N/m, ``exponent`` 1).
    yield_penetration : float
        The penetration (m, > 0; inf: none) past which the Hertz contact yields
        (:attr:`synth.physics.contact_law.ContactLaw.yield_penetration`; exponent 1.5)."""

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
    yield_penetration: float = _INF

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
        checked["yield_penetration"] = check_yield_penetration(
            self.yield_penetration, checked["exponent"]
        )
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
            c.yield_penetration,
        )

    def solve_drop(
        self, speed: float, start: float, *, position, energy_floor: float, max_duration: float,
        max_impacts: int,
    ) -> DropImpacts:  # fmt: skip
        """The impacts of a drop on the plate's impedance in one compiled call
        (:func:`~synth.physics.contact_kernels.impacts_explicit`): the first at ``speed`` (m/s)
        ``start`` s after release, the next ones by the bounce scheduler's rules
        (``energy_floor``, ``max_duration`` s, ``max_impacts``), each as :meth:`solve` at
        ``position`` gives it. It stops before an impact :meth:`solve` must take (Radau IIA, an
        edge's admittance) and takes none where the compiled series does not serve (a shell law,
        no plate): :attr:`DropImpacts.end` is then ``"handed-over"``."""
        # as solve() takes them: the automatic choice of integrator at a position
        method = self.method if position is None else "auto"
        if self.shell is not None or method == "Radau" or self.plate is None:
            return DropImpacts((), (), (), "handed-over", float(start), float(speed))
        tau_edge = _INF
        if position is not None:
            x, y = self.plate.check_position(position, "position")
            if self.plate.boundary == "free":
                edge = min(x, self.plate.length - x, y, self.plate.width - y)
                # a little before the edge is felt: solve() decides at the edge itself
                tau_edge = impedance.edge_contact_time(self.plate, edge) * (1.0 - 1e-9)
        # the kernel's arrays grow to at most DROP_CAPACITY impacts: beyond, the series
        # is handed over after that many (solve() goes on, one call each)
        take = min(int(max_impacts), DROP_CAPACITY)
        announce("contact")
        count, end, t, v, results, times, speeds, hists, rows = _k.impacts_explicit(
            self.mass, self.stiffness, self._beta_inf, self.gravity, self.exponent,
            self.dissipation, self.viscous_time,
            _kernel_yield(
                self.yield_penetration, self.mass, self.stiffness, self.gravity,
                self._beta_inf, float(speed),
            ),
            0.0, self.rtol * TOLERANCE_SAFETY,
            method == "auto", float(speed), float(start), float(energy_floor),
            float(max_duration), take, tau_edge, ENERGY_RESIDUAL_LIMIT,
        )  # fmt: skip
        ending = _k.BOUNCE_ENDS[end]
        if ending == "max-impacts" and take < max_impacts:
            ending = "handed-over"
        rows = rows.tolist()
        solved = tuple(
            _result(r, hists[rows[i] : rows[i + 1]], self.exponent, self.n_points)
            for i, r in enumerate(results.tolist())
        )
        return DropImpacts(tuple(times.tolist()), tuple(speeds.tolist()), solved, ending, t, v)

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
        """The impact at ``speed`` (m/s, downward). The admittance is ``admittance`` (m/(N s)) if
        given; else, with ``position`` (m from a corner), the one near free edges
        (:func:`synth.physics.impedance.point_admittance`); else the infinite plate's.
        ``free_velocity``: the surface's velocity before the impact, m/s, positive upward."""
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
                self.yield_penetration,
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
                self.yield_penetration,
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
            delta_y=self.yield_penetration,
        )
