"""The outcome of one impact, its pulse sampled from the solver's dense output on first access;
the hollow ball's thin-shell impact (docs/physics.md, "Hollow balls")."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np

from synth.errors import ParameterError
from synth.physics import contact_kernels as _k
from synth.physics.contact_kernels import equations as _eq
from synth.physics.contact_kernels import outcome as _o
from synth.physics.contact_kernels import shell as _shell
from synth.physics.contact_law import ShellLaw

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


def _energy_message(residual: float) -> str:
    return (
        f"The energy balance is not met: residual {residual:.3g} of the energy "
        f"exchanged (at most {ENERGY_RESIDUAL_LIMIT:g}); the result is not physical."
    )


class DenseOutput(NamedTuple):
    """The dense output of one contact, the pulse kernels' one argument: step history, integrator,
    dimensionless ``law``, end ``s_contact`` and scales (``theta`` s, ``f_scale`` N)."""

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

    def _sample_pulse(self):
        # both arrays at once, cached on first use (rendering needs only force_at)
        d = self._dense
        times = np.empty(d.n_points)
        forces = np.empty(d.n_points)
        _k.pulse(d, self.status == _eq.SEPARATED, times, forces)
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
        _k.force_slope_at(d, s, out, slope)
        out *= d.f_scale
        slope *= d.f_scale / d.theta


#: The fields of :class:`ImpactResult` copied from a kernel's result array, and their columns.
_ROW_FIELDS = (
    ("restitution", _o.R_RESTITUTION), ("contact_time", _o.R_CONTACT_TIME),
    ("separation_time", _o.R_SEPARATION_TIME), ("max_penetration", _o.R_MAX_PENETRATION),
    ("peak_force", _o.R_PEAK_FORCE), ("impulse", _o.R_IMPULSE),
    ("inelasticity", _o.R_INELASTICITY), ("rebound_speed", _o.R_REBOUND_SPEED),
    ("plate_energy", _o.R_PLATE_ENERGY),
)  # fmt: skip


def result_from_row(cls: type[ImpactResult], r: list, method: str, dense) -> ImpactResult:
    """The ``cls`` of kernel result ``r``; a residual above the limit makes it a failure."""
    status = int(r[_o.R_STATUS])
    residual = r[_o.R_ENERGY_RESIDUAL]
    message = _TINY_REBOUND if r[_o.R_TINY_REBOUND] else _MESSAGES.get(status, "Unknown status.")
    if status >= 0 and not residual <= ENERGY_RESIDUAL_LIMIT:
        status, message = ENERGY_IMBALANCE, _energy_message(residual)
    values = {name: r[column] for name, column in _ROW_FIELDS}
    values.update(
        settled=status == _eq.SETTLED, energy_residual=residual, success=status >= 0,
        status=status, message=message, n_steps=int(r[_o.R_N_STEPS]), method=method,
        _dense=dense,
    )  # fmt: skip
    # the solver's own values need no checks (__init__ would cost much of an impact's time)
    obj = object.__new__(cls)
    object.__setattr__(obj, "__dict__", values)
    return obj


def with_message(result: ImpactResult, message: str) -> ImpactResult:
    """A copy of ``result`` with another ``message``."""
    obj = object.__new__(type(result))
    d = {k: v for k, v in result.__dict__.items() if k not in ("time", "force")}
    d["message"] = message
    object.__setattr__(obj, "__dict__", d)
    return obj


class ShellDense(NamedTuple):
    """Dense output of a thin-shell contact (scales ``theta`` s, ``f_scale`` N)."""

    hist: np.ndarray
    law: tuple
    s_contact: float
    theta: float
    f_scale: float
    n_points: int


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

    def _sample_pulse(self):
        d = self._dense
        s = np.linspace(0.0, d.s_contact, d.n_points)
        forces = np.empty(d.n_points)
        _shell.shell_force_slope(d, s, forces, np.empty(d.n_points))
        if self.status != _eq.SEPARATED:
            forces[-1] = _shell_force_at_end(d)
        times = s * d.theta
        forces *= d.f_scale
        self.__dict__.update(time=times, force=forces)
        return times, forces

    def _pulse_force_slope(self, step, points, offset, period, samples, out) -> None:
        """:meth:`pulse_samples` into ``out`` from the shell kernel's dense output."""
        total = points + samples
        s = np.empty(total)
        s[:points] = np.arange(points) * step
        s[points:] = offset + np.arange(samples) * period
        s /= self._dense.theta
        self._force_and_slope(s, out[0, :total], out[1, :total])

    def _force_and_slope(self, s, out, slope) -> None:
        d = self._dense
        _shell.shell_force_slope(d, s, out, slope)
        out *= d.f_scale
        slope *= d.f_scale / d.theta


def _shell_force_at_end(d: ShellDense) -> float:
    """The dimensionless force at the end of a settled contact's dense output."""
    row = d.hist[-1]
    return _shell.shell_force(row[_shell.S_X1], row[_shell.S_W1], d.law)[0]


def solve_shell(m, law: ShellLaw, beta, v_in, g, v_free, local_tol, n_points) -> ShellImpactResult:
    """One impact of the thin-shell ``law`` (SI) to the local tolerance ``local_tol``."""
    k0 = law.stiffness
    rR = law.reissner_stiffness / k0
    r, hist = _shell.shell_impact(
        m, k0, rR, law.transition, 1.0 - rR, law.viscous_time, beta, v_in, g, v_free, local_tol
    )
    r = r.tolist()
    shell = _shell.Shell(
        r[_o.R_INELASTICITY], r[_o.R_G], rR, r[_o.R_XT], 1.0 - rR, law.viscous_time / r[_o.R_THETA]
    )
    dense = ShellDense(hist, shell, r[_o.R_S_CONTACT], r[_o.R_THETA], r[_o.R_F_SCALE], n_points)
    return result_from_row(ShellImpactResult, r, "DOPRI5", dense)
