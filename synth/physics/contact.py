"""One impact of a ball on a plate's contact stiffness and mechanical impedance under the laws
of docs/physics.md, "Hertz contact" (thesis eqs. 2.9-2.11, 2.34, 2.42; Hunt & Crossley 1975;
Kuwabara & Kono 1987; Brilliantov et al. 1996). The kernels integrate to ``rtol *``
:data:`TOLERANCE_SAFETY`, chosen with ``synth bench contact`` so that the global errors of
restitution and contact time stay below ``rtol``."""

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
from synth.physics.contact_kernels import equations as _eq
from synth.physics.contact_kernels import outcome as _o
from synth.physics.contact_law import ShellLaw, contact_parameters
from synth.physics.contact_result import ENERGY_IMBALANCE as ENERGY_IMBALANCE
from synth.physics.contact_result import ENERGY_RESIDUAL_LIMIT as ENERGY_RESIDUAL_LIMIT
from synth.physics.contact_result import (
    DenseOutput,
    ImpactResult,
    result_from_row,
    solve_shell,
    with_message,
)
from synth.physics.contact_result import ShellImpactResult as ShellImpactResult
from synth.physics.scene import Ball, Plate

#: Local tolerance of the integrators relative to the requested ``rtol``.
TOLERANCE_SAFETY = 0.2
#: Fewest samples of a force pulse over the contact.
MIN_POINTS = 64

_METHODS = {"auto": _k.AUTO, "DOP853": _k.DOP853, "Radau": _k.RADAU}
#: Most impacts of a drop solved in one compiled call (about 200 bytes each).
DROP_CAPACITY = 100_000
_INF = math.inf


def solve_contact(  # noqa: PLR0913 (the public keyword API)
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
    """One impact from lumped parameters: ``mass`` (kg), ``stiffness`` ``K`` (N/m^n) and
    ``exponent`` ``n`` in (1, 4] of ``F = K delta^n``, the plate's ``admittance`` ``1/Z`` (m/(N s),
    0: rigid), ``speed`` (m/s, downward), ``gravity`` (m/s^2), Hunt-Crossley ``dissipation`` (s/m),
    viscoelastic ``viscous_time`` (s, n = 1.5 only), the surface's ``plate_velocity`` (m/s, upward,
    constant over the contact); ``rtol`` in [1e-12, 0.1] for restitution and contact time;
    ``n_points`` >= 64 pulse samples; ``method`` "auto", "DOP853" or "Radau"."""
    # plain floats inside their ranges (the usual call) skip the checks
    values = dict(
        mass=mass, stiffness=stiffness, exponent=exponent, dissipation=dissipation,
        gravity=gravity, rtol=rtol, n_points=n_points, method=method, viscous_time=viscous_time,
    )  # fmt: skip
    if (
        all(type(values[k]) is float for k in _FLOAT_FIELDS)
        and type(n_points) is int
        and type(admittance) is float
        and 0.0 < mass < _INF
        and 0.0 < stiffness < _INF
        and 0.0 <= admittance < _INF
        and 0.0 <= gravity < _INF
        and 1.0 < exponent <= 4.0
        and 0.0 <= dissipation < _INF
        and 0.0 <= viscous_time < _INF
        and (viscous_time == 0.0 or exponent == 1.5)
        and 1e-12 <= rtol <= 0.1
        and n_points >= MIN_POINTS
        and type(method) is str
        and method in _METHODS
    ):
        solver = ContactSolver._unchecked(**values)
    else:
        solver = ContactSolver(**values)
        admittance = checks.nonnegative("admittance", admittance, "m/(N s)")
    speed, plate_velocity = _approach(speed, plate_velocity, "plate_velocity")
    return solver._solve_beta(admittance, speed, plate_velocity)


_FLOAT_FIELDS = ("mass", "stiffness", "exponent", "dissipation", "gravity", "rtol", "viscous_time")


def _approach(speed, v_free, field: str) -> tuple[float, float]:
    """``speed`` and ``v_free`` (m/s) as floats whose sum, the approach speed, is > 0."""
    if not (type(speed) is float and 0.0 < speed < _INF):
        speed = checks.positive("speed", speed, "m/s")
    if not (type(v_free) is float and -_INF < v_free < _INF):
        v_free = checks.real(field, v_free, "m/s")
    if not speed + v_free > 0.0:
        raise ParameterError(
            f"speed={speed!r} with {field}={v_free!r}: the approach speed speed + {field} "
            f"must be > 0 (m/s) for the ball to hit the plate"
        )
    return speed, v_free


def check_law_fields(law) -> dict:
    """The checked fields (SI) of a power law's solver."""
    n = checks.in_range("exponent", law.exponent, 1.0, 4.0, "dimensionless", hi_open=False)
    A, dy = law.viscous_time, law.yield_penetration
    A_checked = checks.nonnegative("viscous_time", A, "s")
    dy_checked = dy if dy == _INF else checks.positive("yield_penetration", dy, "m")
    return dict(
        mass=checks.positive("mass", law.mass, "kg"),
        stiffness=checks.positive("stiffness", law.stiffness, "N/m^n"),
        exponent=n,
        dissipation=checks.nonnegative("dissipation", law.dissipation, "s/m"),
        gravity=checks.nonnegative("gravity", law.gravity, "m/s^2"),
        viscous_time=_hertz_only("viscous_time", A, A_checked, n, "the viscoelastic loss"),
        yield_penetration=_hertz_only("yield_penetration", dy, dy_checked, n, "the yield"),
    )


def _hertz_only(name: str, value, checked: float, exponent: float, what: str) -> float:
    """``checked`` if off (0 or inf) or the law is Hertz's, else ``ParameterError``."""
    if checked not in (0.0, _INF) and exponent != 1.5:
        raise ParameterError(
            f"{name}={value!r} with exponent={exponent!r}: {what} applies to the Hertz "
            f"exponent 1.5 only"
        )
    return checked


def check_points(n_points) -> int:
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


def _result(r: list, hist, n: float, n_points: int) -> ImpactResult:
    """The :class:`ImpactResult` of a kernel result ``r`` and dense output ``hist``."""
    stiff = bool(r[_o.R_STIFF])
    xy = None if r[_o.R_XY] == _INF else r[_o.R_XY]
    law = _eq.Law(r[_o.R_INELASTICITY], r[_o.R_G], n, r[_o.R_C], r[_o.R_B], xy)
    dense = DenseOutput(
        hist, stiff, law, r[_o.R_S_CONTACT], r[_o.R_THETA], r[_o.R_F_SCALE], n_points
    )
    return result_from_row(ImpactResult, r, "Radau" if stiff else "DOP853", dense)


def solve_impact(  # noqa: PLR0913 (the public keyword API)
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
    """The impact of ``ball`` on ``plate`` at ``speed`` (m/s) at ``position`` (m from a corner;
    None: the infinite plate's impedance; near an edge admittance and contact time are solved
    together by fixed-point iteration), under ``gravity`` (m/s^2) and the ``contact`` law (None: the
    ball's own); ``rtol``, ``plate_velocity`` (m/s) and ``n_points`` as :func:`solve_contact`'s."""
    solver = ContactSolver.for_pair(
        ball, plate, gravity=gravity, law=contact, rtol=rtol, n_points=n_points,
        dissipation=dissipation, viscous_time=viscous_time, exponent=exponent,
        stiffness=stiffness, layer_depth=layer_depth, surface=surface,
    )  # fmt: skip
    speed, plate_velocity = _approach(speed, plate_velocity, "plate_velocity")
    return solver.solve(speed, position=position, free_velocity=plate_velocity)


#: Most contact solutions spent on the admittance near an edge (fixed point and bisection).
EDGE_ITERATIONS = 80


@dataclass(frozen=True, eq=False)
class DropImpacts:
    """The impacts of a drop solved in one compiled call: starts (``times``, s), speeds (m/s),
    results and how the series ended (``"handed-over"``: the caller goes on at ``next_time``,
    s, with ``next_speed``, m/s)."""

    times: tuple[float, ...]
    speeds: tuple[float, ...]
    results: tuple[ImpactResult, ...]
    end: str
    next_time: float
    next_speed: float


@dataclass(frozen=True, eq=False)
class ContactSolver:
    """Impacts of one ball on one plate under one contact law, at any speed: checked and
    derived once, then asked by :meth:`solve`. Fields as :func:`solve_contact`'s (SI);
    ``plate``: its admittance, also near edges (None: lumped); ``shell``: a hollow ball's
    :class:`~synth.physics.contact_law.ShellLaw` (``stiffness`` its ``k0``, N/m, ``exponent``
    1); ``yield_penetration`` (m; inf: none)."""

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
        checked = dict(
            rtol=checks.in_range(
                "rtol", self.rtol, 1e-12, 0.1, "dimensionless", lo_open=False, hi_open=False
            ),
            n_points=check_points(self.n_points),
        )
        law = self.shell
        if law is None:
            checked.update(check_law_fields(self))
            checked["method"] = checks.choice("method", self.method, _METHODS)
        elif not isinstance(law, ShellLaw):
            raise ParameterError(f"shell={law!r} must be a ShellLaw or None")
        elif (self.stiffness, self.exponent, self.dissipation, self.viscous_time) != (
            law.stiffness, 1.0, 0.0, law.viscous_time,
        ):  # fmt: skip
            raise ParameterError(
                f"stiffness={self.stiffness!r}, exponent={self.exponent!r}, dissipation="
                f"{self.dissipation!r}, viscous_time={self.viscous_time!r}: with a shell law they "
                f"are its own ({law.stiffness!r}, 1.0, 0.0, {law.viscous_time!r})"
            )
        else:
            checked.update(
                mass=checks.positive("mass", self.mass, "kg"),
                gravity=checks.nonnegative("gravity", self.gravity, "m/s^2"),
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
    def _unchecked(cls, **fields) -> ContactSolver:
        """A solver of checked values without a plate (``__init__`` costs much of an impact)."""
        solver = object.__new__(cls)
        solver.__dict__.update(
            plate=None, shell=None, yield_penetration=_INF, _beta_inf=None, **fields
        )
        return solver

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
        """The solver of ``ball`` on ``plate`` under ``law`` (None: the ball's own); g in m/s^2."""
        if not isinstance(ball, Ball):
            raise ParameterError(f"ball={ball!r} must be a Ball")
        if not isinstance(plate, Plate):
            raise ParameterError(f"plate={plate!r} must be a Plate")
        c = contact_parameters(ball, plate, law, **contact_options)
        return cls(
            ball.mass, c.stiffness, c.exponent, c.dissipation, gravity, rtol, n_points, plate,
            method, c.viscous_time, c.shell, c.yield_penetration,
        )  # fmt: skip

    def solve_drop(
        self, speed: float, start: float, *, position, energy_floor: float, max_duration: float,
        max_impacts: int,
    ) -> DropImpacts:  # fmt: skip
        """The impacts of a drop in one compiled call, the first at ``speed`` (m/s) ``start`` s
        after release, each as :meth:`solve` at ``position`` gives it; handed over before an
        impact only :meth:`solve` can take (Radau IIA, an edge), at once for a shell law or
        without a plate. ``max_duration`` in s."""
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
        # beyond DROP_CAPACITY the series is handed over (solve() goes on, one call each)
        take = min(int(max_impacts), DROP_CAPACITY)
        announce("contact")
        rules = _k.Rules(
            float(energy_floor), float(max_duration), take, tau_edge, ENERGY_RESIDUAL_LIMIT
        )
        count, end, t, v, results, hists, rows = _k.impacts_explicit(
            self._lumped(self._beta_inf, float(speed), 0.0), self.rtol * TOLERANCE_SAFETY,
            method == "auto", float(speed), float(start), rules,
        )  # fmt: skip
        ending = _k.BOUNCE_ENDS[end]
        if ending == "max-impacts" and take < max_impacts:
            ending = "handed-over"
        rows = rows.tolist()
        solved = tuple(
            _result(r, hists[rows[i] : rows[i + 1]], self.exponent, self.n_points)
            for i, r in enumerate(results.tolist())
        )
        times, speeds = tuple(results[:, _k.R_T1].tolist()), tuple(results[:, _k.R_V1].tolist())
        return DropImpacts(times, speeds, solved, ending, t, v)

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
        """The impact at ``speed`` (m/s, downward) at ``admittance`` (m/(N s)) if given, else at
        ``position`` (m) near free edges, else the infinite plate's. ``free_velocity``: m/s,
        upward."""
        v, v_free = _approach(speed, free_velocity, "free_velocity")
        if admittance is not None:
            if position is not None:
                raise ParameterError("give admittance or position, not both")
            beta = checks.nonnegative("admittance", admittance, "m/(N s)")
            return self._solve_beta(beta, v, v_free)
        if self.plate is None:
            raise ParameterError("a ContactSolver without a plate needs admittance (m/(N s))")
        if position is None:
            return self._solve_beta(self._beta_inf, v, v_free)
        x, y = self.plate.check_position(position, "position")
        return self._solve_at(x, y, v, v_free)

    def _solve_beta(self, beta: float, v_in: float, v_free: float, method=None):
        """:meth:`solve` on checked floats (``beta`` m/(N s), speeds m/s)."""
        tol = self.rtol * TOLERANCE_SAFETY
        if self.shell is not None:
            return solve_shell(
                self.mass, self.shell, beta, v_in, self.gravity, v_free, tol, self.n_points
            )
        L = self._lumped(beta, v_in, v_free)
        r, hist = _k.impact(L, v_in, tol, _METHODS[method or self.method])
        return _result(r.tolist(), hist, self.exponent, self.n_points)

    def _lumped(self, beta: float, v_in: float, v_free: float):
        """The kernels' lumped parameters at ``beta`` (m/(N s)), ``v_in``, ``v_free`` (m/s)."""
        m, K, g = self.mass, self.stiffness, self.gravity
        # None where the yield is out of reach: numba then runs the kernels compiled without it
        delta_y = self.yield_penetration
        if delta_y == _INF or not _k.yield_reachable(delta_y, K, m, g, beta, v_in + v_free):
            delta_y = None
        return _k.Lumped(
            m, K, self.exponent, beta, g, self.dissipation, self.viscous_time, delta_y, v_free
        )

    def _solve_at(self, x: float, y: float, v_in: float, v_free: float) -> ImpactResult:
        """The impact at ``(x, y)`` (m) at the admittance near edges: the root of ``A(tau(beta))
        = beta`` (``tau`` the contact time) by bracketed fixed-point iteration and bisection, to
        ``|r| <= rtol beta / 10``."""
        plate, beta_inf, tol = self.plate, self._beta_inf, self.rtol
        result = self._solve_beta(beta_inf, v_in, v_free, "auto")
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
            result = self._solve_beta(beta, v_in, v_free, "auto")
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
