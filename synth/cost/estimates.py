"""The whole estimates: a render's (:func:`estimate`, :func:`estimate_render` from its
options) and a live body's (:func:`body_cost`, checked by :func:`check_body`).
"""

from __future__ import annotations

import math

from synth.cost.contact import (
    hertz_contact_time,
    impact_count,
    series_longest,
    series_seconds,
    solve_first_contact,
    tail_seconds,
)
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
