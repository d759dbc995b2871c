"""One impact of a ball on a plate (docs/physics.md, "Hertz contact", "Hollow balls"); the pulse is
sampled from the solver's dense output on first access. The kernels integrate to ``rtol *``
:data:`TOLERANCE_SAFETY` so that restitution and contact time stay within ``rtol``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np

from synth import checks
from synth.compilation import announce
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics import contact_kernels as _k
from synth.physics import impedance
from synth.physics.contact_kernels import equations as _eq
from synth.physics.contact_kernels import shell as _shell
from synth.physics.contact_law import ShellLaw, contact_parameters
from synth.physics.scene import Ball, Plate, check_type

#: Local tolerance of the integrators relative to the requested ``rtol``.
TOLERANCE_SAFETY = 0.2
#: Fewest samples of a force pulse over the contact.
MIN_POINTS = 64

_METHODS = {"auto": _k.AUTO, "DOP853": _k.DOP853, "Radau": _k.RADAU}
#: Most impacts of a drop solved in one compiled call (about 200 bytes each).
DROP_CAPACITY = 100_000
_INF = math.inf

_MESSAGES = {
    _eq.SEPARATED: "The ball separated from the plate.",
    _eq.SETTLED: "The ball settled: its energy fell below what a separation needs.",
    _eq.MAX_STEPS: "The step limit was reached before the contact ended.",
    _eq.STEP_TOO_SMALL: "The step size fell below the resolution of the time axis.",
}
_TINY_REBOUND = (
    "The ball separated with a rebound speed below the solver's resolution; "
    "restitution reported as 0."
)
#: Status of a contact integrated to its end whose energy balance is not met.
ENERGY_IMBALANCE = -3
#: Largest relative energy residual of a success: the solver meets its tolerance at 1e-7 and
#: below; 1 % means the integration lost the physics (a contact shorter than its time axis).
ENERGY_RESIDUAL_LIMIT = 0.01


class DenseOutput(NamedTuple):
    """The dense output of one contact, the pulse kernels' one argument: step history, integrator
    (Radau IIA or not), dimensionless ``law`` (a shell's too), end ``s_contact`` and scales
    (``theta`` s, ``f_scale`` N)."""

    hist: np.ndarray
    radau: bool
    law: tuple
    s_contact: float
    theta: float
    f_scale: float
    n_points: int


@dataclass(frozen=True, eq=False)
class ImpactResult:
    """The outcome of one impact (SI): ``restitution`` ``v_out / v_in`` (0 when settled);
    ``contact_time`` (s), the force pulse's length (what a force transducer measures);
    ``separation_time`` (s), to the penetration's return to 0 (later with a loss, docs/physics.md,
    "Contact losses"); ``max_penetration`` (m), ``peak_force`` (N), ``impulse`` (N s); Zener's
    ``inelasticity`` ``beta m / theta``; ``settled``; ``rebound_speed`` (m/s); ``plate_energy``
    ``beta Int F^2 dt`` (J); ``time``, ``force`` (s, N): the pulse to separation;
    ``energy_residual``, relative to the energy exchanged; ``status`` 0 separated, 1 settled,
    negative a failure (-3: the balance off by more than ``ENERGY_RESIDUAL_LIMIT``), with
    ``message``; ``n_steps``; ``method``, ``"DOP853"``, ``"Radau"`` or ``"DOPRI5"`` (shell law)."""

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
        """Exponent ``n`` of ``F = K delta^n``: the pulse goes like ``t^n`` and ``(tau - t)^n``."""
        return self._dense.law.n

    @property
    def pulse_order(self) -> float:
        """Exponent ``q`` of the trapezoid rule's error ``C h^q`` on the pulse (the modal bank
        extrapolates with it): ``n + 1``, ``3/2`` with the viscoelastic loss."""
        d = self._dense
        if d is not None and d.law.b != 0.0:
            return 1.5
        return self.exponent + 1.0

    #: The kernel of the force and its rate at dimensionless times.
    _force_slope = staticmethod(_k.force_slope_at)

    def _sample_pulse(self):
        # both arrays at once, cached on first use (rendering needs only force_at)
        d = self._dense
        s = np.linspace(0.0, d.s_contact, d.n_points)
        forces = np.empty(d.n_points)
        self._force_slope(d, s, forces, np.empty(d.n_points))
        if self.status == _eq.SEPARATED:
            forces[-1] = 0.0
        times = s * d.theta
        forces *= d.f_scale
        self.__dict__.update(time=times, force=forces)
        return times, forces

    def force_at(self, t) -> float | np.ndarray:
        """Contact force (N) at times ``t`` (s from first touch); 0 outside."""
        out, _ = self.force_and_slope_at(np.atleast_1d(t))
        return out.reshape(np.shape(t)) if np.ndim(t) else float(out[0])

    def pulse_samples(
        self, step: float, points: int, offset: float, period: float, samples: int, out=None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Force (N) and rate (N/s) at ``j step`` (s, ``j < points``), then ``offset + m
        period`` (s, ``m < samples``); ``out``: optional (2, >= points + samples) array."""
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
        """:meth:`pulse_samples` into ``out`` in one compiled call."""
        _k.pulse_force_slope(self._dense, step, points, offset, period, samples, out)

    def force_and_slope_at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Force (N) and its rate (N/s) at times ``t`` (s from first touch); 0 outside."""
        s = np.ascontiguousarray(np.asarray(t, dtype=float).ravel() / self._dense.theta)
        out = np.empty_like(s)
        slope = np.empty_like(s)
        self._force_and_slope(s, out, slope)
        return out, slope

    def _force_and_slope(self, s, out, slope) -> None:
        """Force (N) and rate (N/s) at times ``s`` (t / theta) into ``out``, ``slope``."""
        d = self._dense
        self._force_slope(d, s, out, slope)
        out *= d.f_scale
        slope *= d.f_scale / d.theta


#: The fields of :class:`ImpactResult` copied from a kernel's result array, and their columns.
_ROW_FIELDS = (
    ("restitution", _eq.R_RESTITUTION), ("contact_time", _eq.R_CONTACT_TIME),
    ("separation_time", _eq.R_SEPARATION_TIME), ("max_penetration", _eq.R_MAX_PENETRATION),
    ("peak_force", _eq.R_PEAK_FORCE), ("impulse", _eq.R_IMPULSE),
    ("inelasticity", _eq.R_INELASTICITY), ("rebound_speed", _eq.R_REBOUND_SPEED),
    ("plate_energy", _eq.R_PLATE_ENERGY),
)  # fmt: skip


def _from_row(cls, r: list, method: str, hist, law, n_points: int) -> ImpactResult:
    """The ``cls`` of kernel result ``r`` with its dense output ``hist`` under the dimensionless
    ``law``; a residual above the limit makes it a failure."""
    dense = DenseOutput(
        hist, method == "Radau", law, r[_eq.R_S_CONTACT], r[_eq.R_THETA], r[_eq.R_F_SCALE], n_points
    )
    status = int(r[_eq.R_STATUS])
    residual = r[_eq.R_ENERGY_RESIDUAL]
    message = _TINY_REBOUND if r[_eq.R_TINY_REBOUND] else _MESSAGES.get(status, "Unknown status.")
    if status >= 0 and not residual <= ENERGY_RESIDUAL_LIMIT:
        status = ENERGY_IMBALANCE
        message = (
            f"The energy balance is not met: residual {residual:.3g} of the energy exchanged "
            f"(at most {ENERGY_RESIDUAL_LIMIT:g}); the result is not physical."
        )
    values = {name: r[column] for name, column in _ROW_FIELDS}
    values.update(
        settled=status == _eq.SETTLED, energy_residual=residual, success=status >= 0,
        status=status, message=message, n_steps=int(r[_eq.R_N_STEPS]), method=method,
        _dense=dense,
    )  # fmt: skip
    # the solver's own values need no checks (__init__ would cost much of an impact's time)
    obj = object.__new__(cls)
    object.__setattr__(obj, "__dict__", values)
    return obj


def with_message(result: ImpactResult, message: str) -> ImpactResult:
    """A copy of ``result`` with another ``message``."""
    obj = object.__new__(type(result))
    kept = {k: v for k, v in result.__dict__.items() if k not in ("time", "force")}
    object.__setattr__(obj, "__dict__", {**kept, "message": message})
    return obj


class ShellImpactResult(ImpactResult):
    """An :class:`ImpactResult` of the thin-shell law, its pulse from the shell kernel."""

    @property
    def exponent(self) -> float:
        """1: the shell law is linear at first touch (Reissner's stiffness and the gas')."""
        return 1.0

    @property
    def pulse_order(self) -> float:
        """``q`` of the trapezoid rule's error: 2 lossless (force ~ ``t``), 1 with the
        Kelvin-Voigt loss (a step ``A k_R v`` at first touch)."""
        return 1.0 if self._dense.law.a != 0.0 else 2.0

    _force_slope = staticmethod(_shell.shell_force_slope)

    def _pulse_force_slope(self, step, points, offset, period, samples, out) -> None:
        """:meth:`pulse_samples` into ``out`` from the shell kernel's dense output."""
        total = points + samples
        s = np.empty(total)
        s[:points] = np.arange(points) * step
        s[points:] = offset + np.arange(samples) * period
        s /= self._dense.theta
        self._force_and_slope(s, out[0, :total], out[1, :total])


def _solve_shell(m, law: ShellLaw, beta, v_in, g, v_free, local_tol, n_points) -> ShellImpactResult:
    """One impact of the thin-shell ``law`` (SI) to the local tolerance ``local_tol``."""
    k0 = law.stiffness
    rR = law.reissner_stiffness / k0
    r, hist = _shell.shell_impact(
        m, k0, rR, law.transition, 1.0 - rR, law.viscous_time, beta, v_in, g, v_free, local_tol
    )
    r = r.tolist()
    shell = _shell.Shell(
        r[_eq.R_INELASTICITY],
        r[_eq.R_G],
        rR,
        r[_eq.R_XT],
        1.0 - rR,
        law.viscous_time / r[_eq.R_THETA],
    )
    return _from_row(ShellImpactResult, r, "DOPRI5", hist, shell, n_points)


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
    values = dict(
        mass=mass, stiffness=stiffness, exponent=exponent, dissipation=dissipation,
        gravity=gravity, rtol=rtol, n_points=n_points, method=method, viscous_time=viscous_time,
    )  # fmt: skip
    # plain floats inside their ranges (the usual call) skip the checks; written out, as a
    # generator's call would cost more than the impact's own Python
    if (
        type(mass) is type(stiffness) is type(exponent) is type(rtol) is float
        and type(admittance) is type(gravity) is type(dissipation) is type(viscous_time) is float
        and type(n_points) is int
        and type(method) is str
        and 0.0 < mass < _INF
        and 0.0 < stiffness < _INF
        and 0.0 <= admittance < _INF
        and 0.0 <= gravity < _INF
        and 0.0 <= dissipation < _INF
        and 0.0 <= viscous_time < _INF
        and 1.0 < exponent <= 4.0
        and (viscous_time == 0.0 or exponent == 1.5)
        and 1e-12 <= rtol <= 0.1
        and n_points >= MIN_POINTS
        and method in _METHODS
    ):
        solver = ContactSolver._unchecked(**values)
    else:
        solver = ContactSolver(**values)
        admittance = checks.nonnegative("admittance", admittance, "m/(N s)")
    speed, plate_velocity = _approach(speed, plate_velocity, "plate_velocity")
    return solver._solve_beta(admittance, speed, plate_velocity)


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
    dy = law.yield_penetration
    checked = dict(
        exponent=n,
        viscous_time=checks.nonnegative("viscous_time", law.viscous_time, "s"),
        yield_penetration=dy if dy == _INF else checks.positive("yield_penetration", dy, "m"),
        mass=checks.positive("mass", law.mass, "kg"),
        stiffness=checks.positive("stiffness", law.stiffness, "N/m^n"),
        dissipation=checks.nonnegative("dissipation", law.dissipation, "s/m"),
        gravity=checks.nonnegative("gravity", law.gravity, "m/s^2"),
    )
    for name, what in (
        ("viscous_time", "the viscoelastic loss"),
        ("yield_penetration", "the yield"),
    ):
        if checked[name] not in (0.0, _INF) and n != 1.5:
            raise ParameterError(
                f"{name}={getattr(law, name)!r} with exponent={n!r}: {what} applies to the Hertz "
                f"exponent 1.5 only"
            )
    return checked


def check_points(n_points) -> int:
    """``n_points`` as an int >= :data:`MIN_POINTS`, or ``ParameterError``."""
    what = "samples of the force pulse over the contact"
    return checks.integer_at_least("n_points", n_points, MIN_POINTS, what)


def _result(r: list, hist, n: float, n_points: int) -> ImpactResult:
    """The :class:`ImpactResult` of a kernel result ``r`` and dense output ``hist``."""
    law = _eq.Law(r[_eq.R_INELASTICITY], r[_eq.R_G], n, r[_eq.R_C], r[_eq.R_B], r[_eq.R_XY])
    return _from_row(ImpactResult, r, "Radau" if r[_eq.R_STIFF] else "DOP853", hist, law, n_points)


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
        check_type("ball", ball, Ball)
        check_type("plate", plate, Plate)
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
            self._lumped(self._beta_inf, 0.0), self.rtol * TOLERANCE_SAFETY,
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
            return _solve_shell(
                self.mass, self.shell, beta, v_in, self.gravity, v_free, tol, self.n_points
            )
        L = self._lumped(beta, v_free)
        r, hist = _k.impact(L, v_in, tol, _METHODS[method or self.method])
        return _result(r.tolist(), hist, self.exponent, self.n_points)

    def _lumped(self, beta: float, v_free: float):
        """The kernels' lumped parameters at ``beta`` (m/(N s)) and ``v_free`` (m/s)."""
        return _k.Lumped(
            self.mass, self.stiffness, self.exponent, beta, self.gravity, self.dissipation,
            self.viscous_time, float(self.yield_penetration), v_free,
        )  # fmt: skip

    def _solve_at(self, x: float, y: float, v_in: float, v_free: float) -> ImpactResult:
        """The impact at ``(x, y)`` (m) at the admittance near edges: the root of ``A(tau(beta))
        = beta`` (``tau`` the contact time) by bracketed fixed-point iteration and bisection, to
        ``|r| <= rtol beta / 10``."""
        plate, beta_inf, tol = self.plate, self._beta_inf, self.rtol
        beta = lo = beta_inf
        result = self._solve_beta(beta, v_in, v_free, "auto")
        edge = min(x, plate.length - x, y, plate.width - y)
        if (
            plate.boundary != "free"
            or not result.success
            or impedance.critical_distance(plate, result.contact_time) <= edge
        ):
            return result
        hi = beta_inf / impedance.CORNER_RATIO
        settled_lo = settled_hi = False
        best = None
        for it in range(EDGE_ITERATIONS + 1):
            target = impedance.admittance_at(plate, x, y, result.contact_time, beta_inf)
            if best is None or abs(target - beta) < best[0]:
                best = (abs(target - beta), result, beta)
            if it == EDGE_ITERATIONS:
                break
            resid = target - beta
            if abs(resid) <= 0.1 * tol * beta:
                return result
            if resid > 0.0:
                lo, settled_lo = beta, result.settled
            else:
                hi, settled_hi = beta, result.settled
            if hi - lo <= 0.1 * tol * hi:
                # e = 0 on both sides: only the landing transient depends on beta there
                why = (
                    "the ball settles on both sides, and the contact time of a settled contact "
                    "(when settling was proven) does not fix the distance at which the edge is felt"
                    if settled_lo and settled_hi
                    else "the contact switches between settling and separating there"
                )
                err, res_b, beta_b = best
                return with_message(
                    res_b,
                    f"{res_b.message} The edge admittance has no consistent value: A(tau(beta)) "
                    f"jumps across beta = {beta_b:.6g} m/(N s) ({why}); the solution there is "
                    f"reported (|A - beta| = {err:.3g} m/(N s)).",
                )
            # fixed-point step while it stays inside the bracket and contracts; else bisect
            beta = target if (lo < target < hi and it < 12) else 0.5 * (lo + hi)
            result = self._solve_beta(beta, v_in, v_free, "auto")
            if not result.success:
                return result
        err, res_b, beta_b = best
        return with_message(
            res_b,
            f"{res_b.message} The edge admittance did not converge in {EDGE_ITERATIONS} contact "
            f"solutions (|A - beta| = {err:.3g} m/(N s) at beta = {beta_b:.6g}).",
        )
