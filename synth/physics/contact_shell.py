"""The thin-shell contact of a hollow ball: its solve and its :class:`ShellImpactResult`.

The law of docs/physics.md, "Hollow balls" (:func:`synth.physics.contact_law.shell_law`),
integrated by :func:`synth.physics.contact_kernels.shell.shell_impact`; the result is
built as the power laws' (:func:`synth.physics.contact_result.result_from_row`), its pulse
sampled from the shell kernel's dense output.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from synth.physics.contact_kernels import equations as _eq
from synth.physics.contact_kernels import outcome as _o
from synth.physics.contact_kernels import shell as _shell
from synth.physics.contact_law import ShellLaw
from synth.physics.contact_result import ImpactResult, result_from_row


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
        _shell.shell_force_slope(d, s, forces, np.empty(d.n_points))
        if self.status != _eq.SEPARATED:
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
        _shell.shell_force_slope(d, s, out, slope)
        out *= d.f_scale
        slope *= d.f_scale / d.theta


def _shell_force_at_end(d: ShellDense) -> float:
    """The dimensionless force at the end of a settled contact's dense output."""
    row = d.hist[-1]
    f, _ = _shell.shell_force(row[_shell.S_X1], row[_shell.S_W1], d.lam, d.rR, d.xt, d.rg, d.a)
    return f


def solve_shell(m, law: ShellLaw, beta, v_in, g, v_free, local_tol, n_points) -> ShellImpactResult:
    """One impact of the thin-shell ``law`` (checked values, SI units; docs/physics.md,
    "Hollow balls"), integrated by :func:`.contact_kernels.shell.shell_impact` to the local
    tolerance ``local_tol`` (the contact's ``rtol`` times its safety factor)."""
    k0 = law.stiffness
    rR = law.reissner_stiffness / k0
    r, hist = _shell.shell_impact(
        m, k0, rR, law.transition, 1.0 - rR, law.viscous_time, beta, v_in, g, v_free, local_tol
    )
    r = r.tolist()
    dense = ShellDense(
        hist, r[_o.R_INELASTICITY], r[_o.R_G], rR, r[_o.R_XT], 1.0 - rR,
        law.viscous_time / r[_o.R_THETA], r[_o.R_S_CONTACT], r[_o.R_THETA], r[_o.R_F_SCALE],
        n_points,
    )  # fmt: skip
    return result_from_row(ShellImpactResult, r, "DOPRI5", dense)
