"""The whole estimates: a render's (:func:`estimate`, :func:`estimate_render` from its
options) and a live body's (:func:`body_cost`, checked by :func:`check_body`); the longest
contact of a bounce series and the audio's length, from the first impact solved alone on the
infinite plate and Hertz' law for the later ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from synth.cost.modal import modal_count, solver_cost
from synth.cost.radiation import radiation_bytes, radiation_work
from synth.cost.records import (
    AUDIO_BYTES_PER_SAMPLE,
    MODE_VALUES,
    BodyCost,
    Budget,
    CostEstimate,
    MemoryParts,
)
from synth.errors import ParameterError
from synth.sound.options import RenderOptions

#: The options of :func:`synth.render` the estimate depends on (:func:`estimate_render`).
RENDER_OPTIONS = (
    "samplerate", "max_frequency", "preroll", "max_duration", "max_tail", "pulse_points",
    "floor_db",
)  # fmt: skip


def estimate_render(scene, options: dict, budget: Budget | None = None) -> CostEstimate:
    """:func:`estimate` of ``scene`` with the render options in ``options`` (a preset's
    ``[render]`` section or a bank row's: ``samplerate`` required, the others of
    :data:`RENDER_OPTIONS` when given and not None, any other key ignored)."""
    given = {k: options[k] for k in RENDER_OPTIONS if options.get(k) is not None}
    return estimate(scene, budget=budget, **given)


def estimate(
    scene, options: RenderOptions | None = None, /, *, budget: Budget | None = None, **overrides
) -> CostEstimate:
    """The :class:`CostEstimate` of rendering ``scene`` with the render ``options`` (a
    :class:`~synth.sound.options.RenderOptions`, and ``overrides`` of its fields by name, as
    :func:`synth.render` takes them; ``samplerate`` in Hz is required); ``budget`` (default:
    the environment's) sets the radiation rules that fit. Nothing is solved but the first
    contact."""
    o = RenderOptions.of(options, **overrides)
    budget = Budget.from_environment() if budget is None else budget
    from synth.sound.modal_bank.pulse import grid_size
    from synth.sound.modal_bank.transform_kernels import WORK_ROWS

    f_max = o.top_frequency
    modes = modal_count(scene.plate, f_max)
    speed = math.sqrt(2.0 * scene.gravity * scene.drop_height)
    first = solve_first_contact(scene)
    settles = first.settled
    longest = (
        first.contact_time if settles else series_longest(first.contact_time, speed, scene.gravity)
    )
    points = grid_size(longest, 2.0 * math.pi * f_max, o.pulse_points)
    series = series_seconds(scene, first, longest, o.max_duration)
    seconds = o.preroll + series + tail_seconds(scene.plate, o.floor_db, o.max_tail)
    samples = int(math.ceil(seconds * o.samplerate))
    solver = solver_cost(scene.plate, f_max, modes)
    impacts = impact_count(first, speed, scene.gravity, o.max_duration)
    memory = MemoryParts(
        audio=AUDIO_BYTES_PER_SAMPLE * samples,
        impacts=16 * modes * (impacts + WORK_ROWS + MODE_VALUES),
        pulse=16 * points,
        solver=solver.solver_bytes,
        shapes=solver.shapes_bytes,
        radiation=radiation_bytes(scene.plate, scene.listener, modes, f_max),
    )
    return CostEstimate(
        max_frequency=f_max,
        modes=modes,
        impact_speed=speed,
        hertz_contact=hertz_contact_time(scene.ball, scene.plate, speed),
        longest_contact=longest,
        settles=settles,
        pulse_points=points,
        audio_seconds=seconds,
        audio_samples=samples,
        memory_bytes=memory.total,
        max_duration=o.max_duration,
        solver_unknowns=solver.unknowns,
        solver_flops=solver.flops,
        impacts=impacts,
        memory=memory,
        radiation=radiation_work(scene.plate, scene.listener, modes, f_max, budget),
    )


def body_cost(
    plate, listener, max_frequency: float, voices: int = 1, budget: Budget | None = None
) -> BodyCost:
    """The :class:`BodyCost` of ``plate`` heard by ``listener`` (an Accelerometer or a
    Microphone) up to ``max_frequency`` (Hz) with ``voices`` voices; ``budget`` (default:
    the environment's) sets the radiation rules that fit. Nothing is solved."""
    budget = Budget.from_environment() if budget is None else budget
    modes = modal_count(plate, max_frequency)
    solver = solver_cost(plate, max_frequency, modes)
    memory = MemoryParts(
        audio=0,
        impacts=16 * modes * (voices + MODE_VALUES),
        pulse=0,
        solver=solver.solver_bytes,
        shapes=solver.shapes_bytes,
        radiation=radiation_bytes(plate, listener, modes, max_frequency),
    )
    return BodyCost(
        max_frequency=max_frequency,
        modes=modes,
        solver_unknowns=solver.unknowns,
        solver_flops=solver.flops,
        radiation=radiation_work(plate, listener, modes, max_frequency, budget),
        memory=memory,
        memory_bytes=memory.total,
    )


def check_body(
    plate, listener, max_frequency: float, voices: int = 1, budget: Budget | None = None
) -> int | None:
    """Check a live body before any work (:func:`body_cost` against ``budget``, default
    the environment's): ``ParameterError`` naming what is too big and what to change, as
    a render's. Returns the ``radiation_max_points`` to pass to
    :func:`synth.sound.render.modal_model` (where the budget stops the sums' refinement;
    None: not stopped)."""
    budget = Budget.from_environment() if budget is None else budget
    cost = body_cost(plate, listener, max_frequency, voices, budget)
    cost.check(budget)
    return cost.radiation.max_points


def hertz_contact_time(ball, plate, speed: float) -> float:
    """Hertz' contact time (s) of ``ball`` on a rigid flat of ``plate``'s material at
    ``speed`` (m/s), :func:`synth.physics.contact_law.hertz_contact_time` with the pair's
    Hertz constant (Johnson, Contact Mechanics, 11.4). For a hollow ball
    (:class:`~synth.physics.scene.HollowBall`), the thin-shell law's at small deflection,
    where it is linear: the half period ``pi sqrt(m / k0)`` (docs/physics.md, "Hollow
    balls"), at any speed."""
    from synth.physics import contact_law
    from synth.physics.scene import HollowBall

    if isinstance(ball, HollowBall):
        return math.pi * math.sqrt(ball.mass / contact_law.shell_law(ball).stiffness)
    stiffness = contact_law.hertz_stiffness(ball, plate)
    return contact_law.hertz_contact_time(ball.mass, stiffness, speed)


def series_longest(first_contact: float, speed: float, gravity: float) -> float:
    """The longest contact (s) of a bouncing series whose first contact at ``speed`` (m/s)
    lasts ``first_contact`` (s): ``tau ~ v^(-1/5)`` (Hertz) down to the slowest impact, where
    the series ends (the flight ``2 v / g`` as short as the contact, or the kinetic energy
    ``floor_db`` below the first impact's)."""
    slowest = _slowest_speed(first_contact, speed, gravity)
    return first_contact * max(1.0, (speed / slowest) ** 0.2)


def _slowest_speed(first_contact: float, speed: float, gravity: float) -> float:
    """The slowest impact of the series of :func:`series_longest`, m/s."""
    from synth.physics.bounces import DEFAULT_FLOOR_DB

    by_flight = (gravity * first_contact * speed**0.2 / 2.0) ** (5.0 / 6.0)
    by_energy = speed * 10.0 ** (DEFAULT_FLOOR_DB / 20.0)
    return max(by_flight, by_energy)


def impact_count(first: FirstContact, speed: float, gravity: float, max_duration: float) -> int:
    """Impacts of the series: speeds ``v e^n`` (``e`` the first impact's restitution) down
    to the slowest, or, for ``e`` near 1, as many flights ``2 v / g`` as fit in
    ``max_duration`` (s); at most the bounce simulation's ``max_impacts``."""
    from synth.physics.bounces import DEFAULT_MAX_IMPACTS as most

    if first.settled:
        return 1
    e = first.restitution
    slowest = _slowest_speed(first.contact_time, speed, gravity)
    by_speed = math.log(slowest / speed) / math.log(e) if 0.0 < e < 1.0 else math.inf
    by_time = max_duration * gravity / (2.0 * speed * max(e, 1e-300))
    return int(min(most, 1 + math.ceil(min(by_speed, max(by_time, 1.0)))))


@dataclass(frozen=True)
class FirstContact:
    """The first impact by the impedance model: ``contact_time`` (s, to separation: the
    span the renderer integrates), ``settled`` (the ball comes to rest), ``restitution``."""

    contact_time: float
    settled: bool
    restitution: float


def solve_first_contact(scene) -> FirstContact:
    """The first impact by the impedance model; for the modal plate, a ball that comes to
    rest gets the modal contact's longest (``SETTLE_FACTOR`` impedance contact times)."""
    from synth.physics.contact import ContactSolver

    c = scene.contact
    options = c.options()
    solver = ContactSolver.for_pair(
        scene.ball, scene.plate, gravity=scene.gravity, law=c.law, rtol=c.rtol, **options
    )
    speed = math.sqrt(2.0 * scene.gravity * scene.drop_height)
    first = solver.solve(speed, position=scene.position)
    if not first.success:  # the render would fail at this impact: say so before any work
        given = [f"contact.law={c.law!r}"]
        given += [f"contact.{k}={v!r}" for k, v in options.items() if k != "surface"]
        raise ParameterError(
            f"the first impact (at {speed:.4g} m/s) could not be solved with "
            f"{', '.join(given)}: {first.message} The scene is outside what the contact "
            f"solver handles"
        )
    e = 0.0 if first.settled else float(first.restitution)
    if c.plate == "impedance" or not first.settled:
        return FirstContact(first.separation_time, bool(first.settled), e)
    # imported here: a scene on the plate's impedance (most renders) needs no modal contact
    from synth.physics.modal_contact.contact import SETTLE_FACTOR, impedance_contact_time

    tau = impedance_contact_time(scene.ball, scene.plate, speed, law=c.law, **options)
    return FirstContact(SETTLE_FACTOR * tau, True, e)


def series_seconds(scene, first: FirstContact, longest: float, max_duration: float) -> float:
    """Length of the bounce series from release, s: the fall, then the flights
    ``2 v e^n / g`` of a constant restitution ``e`` (the first impact's) summed,
    ``2 v e / (g (1 - e))``, and the longest contact; at most ``max_duration``."""
    g = scene.gravity
    fall = math.sqrt(2.0 * scene.drop_height / g)
    speed = g * fall
    e = first.restitution
    flights = math.inf if e >= 1.0 else 2.0 * speed * e / (g * (1.0 - e))
    return min(max_duration, fall + flights + longest)


def tail_seconds(plate, floor_db: float, max_tail: float) -> float:
    """How long the slowest-decaying mode rings before falling ``floor_db`` (dB, < 0)
    below its start, s, at most ``max_tail``: every damping law's decay rate grows with
    frequency, so the slowest is the lowest mode, at the lattice's first wavenumber
    ``k = pi / max(a, b)`` (rad/m)."""
    k = math.pi / max(plate.length, plate.width)
    omega = k * k * math.sqrt(plate.flexural_rigidity / plate.surface_density)
    sigma = float(plate.damping_law().decay_rate(omega))
    nepers = -floor_db / 20.0 * math.log(10.0)
    return min(max_tail, nepers / sigma) if sigma > 0.0 else max_tail
