"""The ball against the plate's modes: the plate's state, one impact and the next landing."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from synth import checks
from synth.compilation import announce
from synth.constants import GRAVITY
from synth.errors import ParameterError
from synth.physics import impedance
from synth.physics.contact import ImpactResult, check_law_fields, check_points, solve_contact
from synth.physics.contact_kernels.equations import yield_law_arrays
from synth.physics.contact_law import contact_parameters
from synth.physics.modal_contact.kernels import (
    BallLaw,
    contact_kernel,
    first_touch,
    force_end,
    hermite,
    ring_free,
)
from synth.physics.modal_contact.point import ModalPoint, modal_point
from synth.physics.scene import Ball, Plate, check_type

#: Band limit of the modes in units of ``1 / tau`` (the impedance model's time to separation):
#: the pulse's spectrum is below -60 dB beyond about ``3 / tau``; the residual covers the rest.
BAND_FACTOR = 4.0
#: Fixed steps over one contact of the impedance model's duration (to separation).
STEPS_PER_CONTACT = 512
#: Contact times after which a contact still going is reported as settled.
SETTLE_FACTOR = 40.0


@dataclass(frozen=True, eq=False)
class PlateRinging:
    """The plate's state under the ball: modal displacements ``q`` (m) and velocities ``v``
    (m/s), band then residual, and the tail's ``x_res`` (m, downward); at rest all zeros."""

    q: np.ndarray
    v: np.ndarray
    x_res: float
    n_band: int

    @property
    def displacement(self) -> float:
        """Displacement of the surface under the ball, m, positive upward."""
        n = self.n_band
        return float(self.q[:n].sum()) + float(self.q[n:].sum()) - self.x_res

    @property
    def velocity(self) -> float:
        """Bending velocity of the surface under the ball, m/s, positive upward."""
        n = self.n_band
        return float(self.v[:n].sum()) + float(self.v[n:].sum())


@dataclass(frozen=True, eq=False)
class ModalImpactResult(ImpactResult):
    """An :class:`~synth.physics.contact.ImpactResult` of the modal contact: the pulse between
    ``step_times`` (s) from the Hermite interpolant of ``step_gaps`` (m) and ``step_rates``
    (m/s); ``contact_loss`` (J) of the law's loss and plastic flow; ``ringing`` the plate at
    separation; ``restitution`` as bounce times measure it."""

    step_times: np.ndarray | None = field(default=None, repr=False)
    step_forces: np.ndarray | None = field(default=None, repr=False)
    step_gaps: np.ndarray | None = field(default=None, repr=False)
    step_rates: np.ndarray | None = field(default=None, repr=False)
    law_stiffness: float = 0.0
    law_exponent: float = 1.5
    law_dissipation: float = 0.0
    law_viscous_time: float = 0.0
    law_yield_penetration: float = math.inf
    contact_loss: float = 0.0
    ringing: PlateRinging | None = field(default=None, repr=False)
    plate_modal_energy: float = 0.0
    n_points: int = 128

    @property
    def exponent(self) -> float:
        return self.law_exponent

    @property
    def pulse_order(self) -> float:
        """``n + 1``, or ``3/2`` with the viscoelastic loss (the force rises like ``t^(1/2)``)."""
        return 1.5 if self.law_viscous_time != 0.0 else self.law_exponent + 1.0

    def _sample_pulse(self):
        times = np.linspace(0.0, self.separation_time, self.n_points)
        forces = self.force_and_slope_at(times)[0]
        self.__dict__.update(time=times, force=forces)
        return times, forces

    def force_and_slope_at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Force (N) and its rate (N/s) at times ``t`` (s from first touch); 0 outside."""
        tt = np.asarray(t, dtype=float).ravel()
        ts = self.step_times
        i = np.clip(np.searchsorted(ts, tt, side="right") - 1, 0, ts.size - 2)
        h = ts[i + 1] - ts[i]
        # the kernel's Python function, on numpy's arrays: the kernel itself would compile
        # once more for arrays (the contact's kernels call it on floats)
        u = (tt - ts[i]) / h
        delta, rate, accel = hermite.py_func(u, h, self.step_gaps, self.step_rates, i)
        inside = (tt >= 0.0) & (tt <= self.separation_time) & (delta > 0.0)
        d = np.ascontiguousarray(np.where(inside, delta, 1.0))
        n = self.law_exponent
        if self.law_yield_penetration == math.inf:
            r = d ** (n - 1.0)
            a, da, dr = r * d, n * r, (n - 1.0) * r / d
        else:
            dm = np.ascontiguousarray(np.maximum.accumulate(self.step_gaps)[i], dtype=float)
            a, r, da, dr = (np.empty_like(d) for _ in range(4))
            yield_law_arrays(d, self.law_yield_penetration, dm, a, r, da, dr)
        K, mu, b = self.law_stiffness, self.law_dissipation, 1.5 * self.law_viscous_time
        c = mu * a + b * r
        force = K * (a + c * rate)
        slope = K * (da * rate + (mu * da + b * dr) * rate * rate + c * accel)
        positive = inside & (force > 0.0)
        return np.where(positive, force, 0.0), np.where(positive, slope, 0.0)

    def pulse_samples(
        self, step: float, points: int, offset: float, period: float, samples: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Force (N) and rate (N/s) at ``j step``, then ``offset + m period`` (s)."""
        t = np.concatenate((np.arange(points) * step, offset + np.arange(samples) * period))
        return self.force_and_slope_at(t)


@dataclass(frozen=True, eq=False)
class ModalContact:
    """Impacts of a ball on a finite plate at one point, the plate as its modes. Fields (SI) as
    :class:`~synth.physics.contact.ContactSolver`'s; ``steps_per_contact``: fixed steps over
    one impedance-model contact time."""

    point: ModalPoint
    mass: float
    stiffness: float
    exponent: float
    gravity: float = GRAVITY
    steps_per_contact: int = STEPS_PER_CONTACT
    dissipation: float = 0.0
    viscous_time: float = 0.0
    yield_penetration: float = math.inf

    def __post_init__(self):
        check_type("point", self.point, ModalPoint)
        checked = check_law_fields(self)
        steps = self.steps_per_contact
        checks.integer_at_least("steps_per_contact", steps, 16, "steps per contact time")
        for key, value in checked.items():
            object.__setattr__(self, key, value)

    @classmethod
    def for_pair(
        cls,
        ball: Ball,
        plate: Plate,
        position: tuple[float, float] | None = None,
        *,
        gravity: float = GRAVITY,
        law: str = "hertz",
        max_frequency: float | None = None,
        speed: float | None = None,
        theory: str = "kirchhoff",
        **contact_options,
    ) -> ModalContact:
        """The modal contact of ``ball`` on ``plate`` at ``position`` (m; None: the centre)
        under ``law``. ``max_frequency`` (Hz) defaults to :data:`BAND_FACTOR` over the
        impedance model's contact time at ``speed`` (m/s; default 1)."""
        check_type("ball", ball, Ball)
        check_type("plate", plate, Plate)
        law_ = contact_parameters(ball, plate, law, **contact_options)
        if law_.shell is not None:
            raise ParameterError(
                "the modal contact integrates the power laws only, not a hollow ball's "
                "contact='shell': solve it on the impedance plate (plate_model='impedance')"
            )
        K, n, mu, A = law_.stiffness, law_.exponent, law_.dissipation, law_.viscous_time
        pos = plate.centre if position is None else position
        if max_frequency is None:
            v = 1.0 if speed is None else checks.positive("speed", speed, "m/s")
            tau = _impedance_contact(ball.mass, K, n, plate, v, mu, A).separation_time
            max_frequency = BAND_FACTOR / tau
        point = modal_point(plate, pos, max_frequency=max_frequency, theory=theory)
        return cls(
            point, ball.mass, K, n, gravity, dissipation=mu, viscous_time=A,
            yield_penetration=law_.yield_penetration,
        )  # fmt: skip

    def at_rest(self) -> PlateRinging:
        """The plate at rest."""
        p = self.point
        n = p.omega.size + p.residual_omega.size
        return PlateRinging(np.zeros(n), np.zeros(n), 0.0, p.omega.size)

    def ring(self, state: PlateRinging, duration: float) -> PlateRinging:
        """The plate's state after ringing freely for ``duration`` (s)."""
        d = checks.nonnegative("duration", duration, "s")
        p = self.point
        q, v = state.q.copy(), state.v.copy()
        if d > 0.0:
            omega, sigma, _ = p.contact_modes
            ring_free(omega, sigma, q, v, d)
        x = state.x_res * math.exp(-p.residual_rate * d)
        return PlateRinging(q, v, x, p.omega.size)

    def energy(self, state: PlateRinging) -> float:
        """Energy in ``state`` (J): modes' ``(v^2 + omega^2 q^2) / (2 c)`` plus the tail spring."""
        p = self.point
        omega, _, coupling = p.contact_modes
        q, v = state.q, state.v
        modal = 0.5 * float(((v**2 + omega**2 * q**2) / coupling).sum())
        return modal + 0.5 * p.residual_rate / p.residual_admittance * state.x_res**2

    def solve(
        self, speed: float, state: PlateRinging | None = None, *, n_points: int = 128
    ) -> ModalImpactResult:
        """The impact at ``speed`` (m/s, down) on the plate in ``state`` (None: at rest)."""
        v_in = checks.positive("speed", speed, "m/s")
        n_points = check_points(n_points)
        p = self.point
        state = self.at_rest() if state is None else state
        n = p.omega.size + p.residual_omega.size
        if state.q.shape != (n,) or state.v.shape != (n,) or state.n_band != p.omega.size:
            raise ParameterError(
                f"state has {state.q.size} oscillators, {state.n_band} of the band; this contact "
                f"has {n}, {p.omega.size} of the band (one per mode)"
            )
        v_approach = v_in + state.velocity
        if not v_approach > 0.0:
            raise ParameterError(
                f"speed={speed!r}: the plate surface moves down faster ({-state.velocity!r} m/s) "
                f"than the ball; the ball cannot hit it"
            )
        ref = _impedance_contact(
            self.mass, self.stiffness, self.exponent, p.plate, v_approach, self.dissipation,
            self.viscous_time,
        )  # fmt: skip
        h = ref.separation_time / self.steps_per_contact
        max_steps = int(SETTLE_FACTOR * self.steps_per_contact)
        q, v = state.q.copy(), state.v.copy()
        x = np.array([state.x_res])
        pulse = np.zeros((4, max_steps + 1))  # times, forces, gaps and rates at the steps
        e0, w0 = self.energy(state), state.displacement
        law = BallLaw(
            self.mass, self.stiffness, self.exponent, self.dissipation, 1.5 * self.viscous_time,
            self.gravity,
        )  # fmt: skip
        dy = float(self.yield_penetration)  # inf: no yield
        announce("modal-contact")
        o = contact_kernel(p.oscillators, q, v, x, law, dy, v_in, h, max_steps, pulse)
        times, forces, gaps, rates = pulse[:, : o.steps + 1].copy()
        ringing = PlateRinging(q, v, float(x[0]), p.omega.size)
        e_plate = self.energy(ringing)
        rigid = 0.5 * o.rigid_v**2 / p.rigid_coupling if p.rigid_coupling > 0.0 else 0.0
        # ball energy in = out + plate energy gained + losses (gravity's work included)
        m = self.mass
        ball_in = 0.5 * m * v_in**2
        ball_out = 0.5 * m * o.v**2 + m * self.gravity * (o.u - w0)
        plate = e_plate - e0 + rigid + o.damping_loss + o.dashpot_loss + o.contact_loss
        residual = abs(ball_in - ball_out - plate) / max(ball_in, e0, abs(plate), 1e-300)
        t_force = o.time
        if o.separated and (law.mu != 0.0 or law.b != 0.0 or dy is not None):
            t_force = force_end(times, forces, gaps, rates, law.mu, law.b, self.yield_penetration)
        message = "The ball separated from the plate." if o.separated else (
            f"The ball did not separate within {SETTLE_FACTOR:g} contact times of the "
            f"impedance model: it rests on the plate."
        )  # fmt: skip
        return ModalImpactResult(
            restitution=o.v / v_in if o.separated and o.v > 0.0 else 0.0, contact_time=t_force,
            separation_time=o.time, max_penetration=o.dmax, peak_force=o.fmax,
            impulse=o.impulse, inelasticity=ref.inelasticity, settled=not o.separated,
            rebound_speed=max(o.v, 0.0) if o.separated else 0.0, plate_energy=plate,
            energy_residual=residual, success=True, status=0 if o.separated else 1,
            message=message, n_steps=o.steps, method="modal", step_times=times,
            step_forces=forces, step_gaps=gaps, step_rates=rates, law_stiffness=self.stiffness,
            law_exponent=self.exponent, law_dissipation=self.dissipation,
            law_viscous_time=self.viscous_time, law_yield_penetration=self.yield_penetration,
            contact_loss=o.contact_loss, ringing=ringing, plate_modal_energy=e_plate,
            n_points=n_points,
        )  # fmt: skip


def next_touch(
    contact: ModalContact, state: PlateRinging, height: float, speed: float
) -> tuple[float, PlateRinging]:
    """The ball's next landing: the first time (s) the ball at ``height`` (m) rising at
    ``speed`` (m/s) meets the plate ringing from ``state``, and the plate's state then."""
    p = contact.point
    g = contact.gravity
    if not g > 0.0:
        raise ParameterError("the ball lands again only with gravity > 0")
    qs, vs = state.q, state.v
    W = abs(state.x_res) + float(np.sqrt(qs**2 + (vs / p.oscillators.omega) ** 2).sum())
    v = speed

    def when(level):  # the later time at which the ball passes ``level`` going down
        disc = v * v + 2.0 * g * (height - level)
        return (v + math.sqrt(max(disc, 0.0))) / g

    dt = 1.0 / (8.0 * p.max_frequency)
    s0 = when(W) if height + v * v / (2.0 * g) > W else dt
    s = first_touch(
        p.oscillators, qs, vs, float(state.x_res), float(height), float(v), float(g), dt, s0,
        when(-W),
    )  # fmt: skip
    return s, contact.ring(state, s)


def _impedance_contact(m, K, n, plate, v, mu, A) -> ImpactResult:
    """The impedance model's impact (``mu`` s/m, ``A`` s): the modal contact's time scale."""
    return solve_contact(
        mass=float(m), stiffness=float(K),
        admittance=1.0 / impedance.infinite_plate_impedance(plate), speed=float(v), gravity=0.0,
        exponent=float(n), dissipation=float(mu), viscous_time=float(A), rtol=1e-6,
    )  # fmt: skip


def impedance_contact_time(
    ball: Ball, plate: Plate, speed: float, *, law: str = "hertz", **contact_options
) -> float:
    """The impedance model's time to separation (s) at ``speed`` (m/s) without gravity."""
    c = contact_parameters(ball, plate, law, **contact_options)
    v = checks.positive("speed", speed, "m/s")
    return _impedance_contact(
        ball.mass, c.stiffness, c.exponent, plate, v, c.dissipation, c.viscous_time
    ).separation_time
