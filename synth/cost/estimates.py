"""A render's and a live body's cost estimates, before any mode is solved: modes counted on
the wavenumber lattice, the radiation rules' work, and the longest contact and the audio's
length from the first impact alone and Hertz' law for the later ones."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth.constants import SOUND_SPEED
from synth.cost.records import (
    AUDIO_BYTES_PER_SAMPLE,
    CHECK_SQUARES,
    MODE_VALUES,
    RADIATION_CHUNKS,
    RADIATION_TOL,
    SOLVER_SQUARES,
    BodyCost,
    Budget,
    CostEstimate,
    MemoryParts,
    RadiationWork,
    SolverCost,
)
from synth.errors import ParameterError
from synth.sound.options import RenderOptions
from synth.sound.radiation.common import CHUNK_BYTES, MAX_RULES, REFINE
from synth.sound.radiation.rules import weighted_counts


def bending_wavenumber(plate, f_max: float) -> float:
    """The bending wavenumber at ``f_max`` (Hz), rad/m."""
    omega = 2.0 * math.pi * f_max
    return math.sqrt(omega * math.sqrt(plate.surface_density / plate.flexural_rigidity))


def modal_count(plate, max_frequency: float) -> int:
    """Modes of ``plate`` below ``max_frequency`` (Hz): the wavenumber lattice
    ``(m pi / a)^2 + (n pi / b)^2 <= k^2``, ``k^4 = omega^2 rho h / D``, counted exactly (exact for
    simply supported edges; clamped counted as such, free by :func:`_free_modal_count`); it adds
    the edges' share to the modal density (Cremer, Heckl & Petersson, eq. 5.118)."""
    k = bending_wavenumber(plate, max_frequency)
    if plate.boundary == "free":
        return _free_modal_count(plate, k)
    kx, ky = k * plate.length / math.pi, k * plate.width / math.pi  # lattice radii
    n = np.arange(1, int(math.floor(ky)) + 1, dtype=float)
    rows = np.floor(kx * np.sqrt(np.maximum(1.0 - (n / ky) ** 2, 0.0)))
    return int(np.sum(np.maximum(rows, 0.0)))


def _free_modal_count(plate, k: float) -> int:
    """Modes of a free ``plate`` whose bending wavenumber ``k`` (rad/m) is the band's top: the
    free beam's functions along each side (Warburton, Proc. Inst. Mech. Eng. 168, 371 (1954);
    Blevins' single-span beams) counted on the lattice ``q_x^2 + q_y^2 <= k^2``, plus the
    twisting modes up to ``q_T^2 = (sqrt(g^2 + 4 k^4) - g) / 2``, ``g = 24 (1 - nu) / b^2``
    (the derivation: docs/cli.md, "The cost of a render, and its budget"), ``w = x y`` once."""
    a, b = plate.length, plate.width
    nu = plate.material.poisson
    qx, qy = _free_beam_wavenumbers(k, a), _free_beam_wavenumbers(k, b)
    reach = np.sqrt(np.maximum(k * k - qy * qy, 0.0))
    bending = int(np.sum(np.searchsorted(qx, reach, side="right")))
    twist_x = _twisting_count(k, a, 24.0 * (1.0 - nu) / (b * b))
    twist_y = _twisting_count(k, b, 24.0 * (1.0 - nu) / (a * a))
    return bending + twist_x + twist_y - (1 if twist_x >= 2 and twist_y >= 2 else 0)


def _free_beam_wavenumbers(k: float, length: float) -> np.ndarray:
    """The free beam's wavenumbers up to ``k`` (rad/m) on ``length`` m, rigid rotation
    left out (:func:`_free_modal_count`): 0, then ``(j - 1/2) pi / length``, ``j >= 2``."""
    j = np.arange(2, int(k * length / math.pi + 0.5) + 1, dtype=float)
    return np.concatenate(([0.0], (j - 0.5) * math.pi / length))


def _twisting_count(k: float, length: float, g: float) -> int:
    """Twisting modes ``q = m pi / length <= q_T`` (``m >= 0``) of :func:`_free_modal_count`,
    ``g`` (1/m^2) the torsional term of their dispersion."""
    q_t = math.sqrt(0.5 * (math.sqrt(g * g + 4.0 * k**4) - g))
    return int(math.floor(q_t * length / math.pi)) + 1


def solver_cost(plate, f_max: float, modes: int) -> SolverCost:
    """The :class:`SolverCost` of ``plate``'s ``modes`` modes up to ``f_max`` (Hz)."""
    from synth.physics import modes as plate_modes

    main, check = plate_modes.solver_sizes(plate, f_max)
    flops = sum(n**3 / 3 + 2 * n**3 / 3 + 9 * n**3 for n in main)
    flops += sum(n**3 / 3 + 2 * n**3 / 3 + 4 * n**3 / 3 for n in check)
    return SolverCost(
        unknowns=max(main + check, default=0),
        flops=float(flops),
        solver_bytes=8 * max(SOLVER_SQUARES * max(main, default=0) ** 2,
                             CHECK_SQUARES * max(check, default=0) ** 2),
        shapes_bytes=8 * max(main, default=0) * modes,
    )  # fmt: skip


def _acoustic(f_max: float) -> float:
    """The acoustic wavenumber at ``f_max`` (Hz), rad/m."""
    return 2.0 * math.pi * f_max / SOUND_SPEED


def _crossed(plate, f_max: float) -> bool:
    """Whether ``plate``'s modes up to ``f_max`` (Hz) pass the Ritz crossover (a free or
    clamped plate with dynamic edge effect modes, :func:`synth.physics.modes.modes`)."""
    from synth.physics.modes import dimensionless_band
    from synth.physics.modes.crossover import crosses

    if plate.boundary == "simply-supported":
        return False
    return crosses(plate.length / plate.width, dimensionless_band(plate, f_max))


def radiation_problem(plate, listener, modes: int, f_max: float, max_points=None):
    """The :class:`synth.sound.radiation.rules.Problem` of ``listener`` (a Microphone)
    hearing ``plate``'s ``modes`` modes up to ``f_max`` (Hz) with ``max_points`` (default:
    the sums' own), before any mode is solved (past the Ritz crossover, its Ritz low band
    and edge effect modes counted by :func:`modal_count`)."""
    from synth.physics.modes import frequency_scale, ritz_band
    from synth.sound import radiation as rad
    from synth.sound.radiation.rules import edge_split, plate_problem

    max_points = rad.DEFAULT_MAX_POINTS if max_points is None else max_points
    kb = bending_wavenumber(plate, f_max)
    edge = None
    if _crossed(plate, f_max):
        # the top of the Ritz low band, Hz: its seam with the edge effect modes lies at or
        # below it (synth.physics.modes.crossover)
        f_low = ritz_band(plate, f_max) * frequency_scale(plate) / (2.0 * math.pi)
        n_low = modal_count(plate, f_low)
        edge = edge_split(kb, f_low, f_max, n_low, lambda f: modal_count(plate, f), SOUND_SPEED)
    return plate_problem(
        plate,
        f_max,
        listener=listener.position,
        modes=modes,
        kb=kb,
        qa=_acoustic(f_max),
        tol=RADIATION_TOL,
        max_points=max_points,
        edge=edge,
    )


def _rules_taken(points, max_points: int | None) -> int:
    """Rules a refinement takes with ``max_points`` (None: no cut): after its first two it
    stops before a rule of more points."""
    taken = 2
    while taken < MAX_RULES and (max_points is None or points[taken] <= max_points):
        taken += 1
    return taken


def _fitted(rule, modes: int, terms: int, budget: Budget) -> RadiationWork:
    """The :class:`RadiationWork` of the counts ``rule`` with the most rules whose summed
    work (rectangle-term equivalents) fits ``budget``: the ``max_points`` that stops the
    refinement there and the rules it then takes; one rule (refused) if not even two fit."""
    rule = weighted_counts(rule)
    rules, cut = 1, int(rule.points[0])
    for last in range(MAX_RULES, 1, -1):
        candidate = None if last == MAX_RULES else int(rule.points[last - 1])
        taken = _rules_taken(rule.points, candidate)
        if rule.fixed + float(sum(rule.work[:taken])) <= budget.max_radiation_work:
            rules, cut = taken, candidate
            break
    points = int(sum(rule.points[:rules]))
    return RadiationWork(
        rule.rule, int(rule.points[0]), points, terms, float(points) * modes, rules, cut,
        tuple(int(p) for p in rule.points), tuple(float(w) for w in rule.work),
        float(rule.fixed), rule.unit,
    )  # fmt: skip


def radiation_work(plate, listener, modes: int, f_max: float, budget: Budget) -> RadiationWork:
    """The :class:`RadiationWork` of ``listener`` hearing ``plate``'s ``modes`` modes up to
    ``f_max`` (Hz), before any mode is solved, for the rule the render takes, with the rules
    whose summed work fits ``budget`` (at least the first)."""
    from synth.physics.modes import shape_terms
    from synth.physics.scene import Microphone
    from synth.sound.radiation.rules import choose_rule

    if not isinstance(listener, Microphone) or modes == 0:
        return RadiationWork()
    terms = shape_terms(plate, f_max)
    problem = radiation_problem(plate, listener, modes, f_max)
    return _fitted(choose_rule(problem).counts, modes, terms, budget)


def radiation_bytes(plate, listener, modes: int, f_max: float) -> int:
    """Bytes of the chunks of shape values a microphone's Rayleigh sums hold
    (:data:`RADIATION_CHUNKS`): each ``modes`` times the points of the check rule at the
    bending plus acoustic wavenumber of ``f_max`` (Hz), at most ``CHUNK_BYTES``."""
    from synth.physics.scene import Microphone
    from synth.sound.radiation import rectangle_points

    if not isinstance(listener, Microphone) or modes == 0:
        return 0
    size = (plate.length, plate.width)
    kappa = bending_wavenumber(plate, f_max) + _acoustic(f_max)
    points = rectangle_points(size, kappa, RADIATION_TOL) * REFINE**2
    chunk = min(float(CHUNK_BYTES), 8.0 * modes * points)
    return int(RADIATION_CHUNKS * chunk)


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
    """The :class:`CostEstimate` of rendering ``scene`` with the options of :func:`synth.render`
    (``samplerate`` in Hz required); ``budget`` sets the radiation rules that fit. Only the
    first contact is solved."""
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
    impacts = impact_count(first, speed, scene.gravity, o.max_duration)
    memory = {
        "audio": AUDIO_BYTES_PER_SAMPLE * samples,
        "impacts": 16 * modes * (impacts + WORK_ROWS + MODE_VALUES),
        "pulse": 16 * points,
    }
    return CostEstimate(
        impact_speed=speed,
        hertz_contact=hertz_contact_time(scene.ball, scene.plate, speed),
        longest_contact=longest,
        settles=settles,
        pulse_points=points,
        audio_seconds=seconds,
        audio_samples=samples,
        max_duration=o.max_duration,
        impacts=impacts,
        **_stages(scene.plate, scene.listener, modes, f_max, budget, **memory),
    )


def _stages(plate, listener, modes: int, f_max: float, budget: Budget, **memory) -> dict:
    """The fields a :class:`CostEstimate` and a :class:`BodyCost` share: the cold mode solve,
    the radiation stage and the memory (``memory`` the audio's, impacts' and pulse's bytes)."""
    solver = solver_cost(plate, f_max, modes)
    parts = MemoryParts(
        **memory,
        solver=solver.solver_bytes,
        shapes=solver.shapes_bytes,
        radiation=radiation_bytes(plate, listener, modes, f_max),
    )
    return dict(
        max_frequency=f_max,
        modes=modes,
        solver_unknowns=solver.unknowns,
        solver_flops=solver.flops,
        radiation=radiation_work(plate, listener, modes, f_max, budget),
        memory=parts,
        memory_bytes=parts.total,
    )


def body_cost(
    plate, listener, max_frequency: float, voices: int = 1, budget: Budget | None = None
) -> BodyCost:
    """The :class:`BodyCost` of ``plate`` heard by ``listener`` (an Accelerometer or a
    Microphone) up to ``max_frequency`` (Hz) with ``voices`` voices; ``budget`` (default:
    the environment's) sets the radiation rules that fit. Nothing is solved."""
    budget = Budget.from_environment() if budget is None else budget
    modes = modal_count(plate, max_frequency)
    impacts = 16 * modes * (voices + MODE_VALUES)
    stages = _stages(
        plate, listener, modes, max_frequency, budget, audio=0, impacts=impacts, pulse=0
    )
    return BodyCost(**stages)


def check_body(
    plate, listener, max_frequency: float, voices: int = 1, budget: Budget | None = None
) -> int | None:
    """Raise ParameterError where :func:`body_cost` is beyond ``budget``; returns the
    ``radiation_max_points`` for :func:`synth.sound.render.modal_model` (None: no cut)."""
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
