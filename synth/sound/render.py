"""Render a scene: bounces -> plate modes -> exact modal synthesis -> level. The signal is
plate acceleration (m/s^2) for an Accelerometer, sound pressure (Pa) for a Microphone above the
baffled plate, scaled by ``normalize``."""

from __future__ import annotations

import functools
import inspect
import math
import time

import numpy as np

from synth import cost
from synth.errors import ParameterError, SynthError
from synth.physics.bounces import BounceSequence, simulate_scene
from synth.physics.scene import Scene
from synth.sound.listener import (
    LISTENER_UNITS,
    ModalModel,
    listener_grid,
    modal_model,
    nearest_distance,
)
from synth.sound.modal_bank import Bank, synthesize
from synth.sound.options import (
    MAX_SAMPLERATE,
    OPTIONS,
    RenderOptions,
    keyword_parameters,
    parameters_doc,
)
from synth.sound.result import Render, RenderInfo
from synth.store import cache as disk_cache

#: Names other modules import from here (their homes are the modules above).
__all__ = [
    "LISTENER_UNITS", "OPTIONS", "ModalModel", "Render", "RenderOptions", "check_sequence",
    "listener_grid", "modal_model", "nearest_distance", "render",
]  # fmt: skip


def render(scene, *, options=None, sequence=None, budget=None, **overrides) -> Render:
    """Render ``scene`` with the render options: ``options`` (a
    :class:`~synth.sound.options.RenderOptions`), or its fields as keywords (``samplerate``
    required: there is no default rate), or both (the keywords win).

    Parameters
    ----------
    scene : Scene
    options : RenderOptions, optional
        The options; a keyword below changes one of them.
    OPTIONS_DOC
    sequence : BounceSequence, optional
        Precomputed impacts of this scene (default: computed here); not empty, and its
        contacts must be this scene's (see :func:`check_sequence`).
    budget : synth.cost.Budget, optional
        Default ``Budget.from_environment()``; a :func:`synth.cost.estimate` beyond it is
        refused before any work (ParameterError).
    """
    o = _checked_options(scene, options, overrides)
    estimate = _checked_work(scene, o, sequence, budget)
    if scene.moving:
        if sequence is not None:
            raise ParameterError(
                "sequence: a scene with drop.velocity computes its own path (bounces and "
                "rolling); pass no sequence"
            )
        return _render_moving(scene, o)
    started = time.perf_counter()
    sequence = _impacts(scene, o, sequence)
    contact_seconds = time.perf_counter() - started
    model = _heard_modes(scene, o, estimate.radiation.max_points)
    return _render_drop(scene, o, sequence, model, contact_seconds)


if render.__doc__:  # None under python -OO
    render.__doc__ = render.__doc__.replace("    OPTIONS_DOC", parameters_doc())
render.__signature__ = inspect.Signature(
    [
        inspect.Parameter("scene", inspect.Parameter.POSITIONAL_OR_KEYWORD),
        *keyword_parameters(),
        *(
            inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=None)
            for name in ("options", "sequence", "budget")
        ),
    ],
    return_annotation=Render,
)


def _checked_options(scene, options, overrides) -> RenderOptions:
    """The scene, damping law, cache environment and options checked before any work."""
    if not isinstance(scene, Scene):
        raise ParameterError(f"scene={scene!r} must be a Scene")
    scene.plate.damping_law()
    disk_cache.check_environment()
    return RenderOptions.of(options, **overrides)


def _checked_work(scene, o: RenderOptions, sequence, budget) -> cost.CostEstimate:
    """The render's cost estimate, refused beyond ``budget`` (default: the environment's),
    as is a first impact later than ``max_duration``."""
    if sequence is None:
        first_touch = math.sqrt(2.0 * scene.drop_height / scene.gravity)
        if first_touch > o.max_duration:
            raise ParameterError(
                f"drop.height={scene.drop_height!r} m: the first impact, {first_touch:.4g} s "
                f"after release, is later than max_duration={o.max_duration!r} (s)"
            )
    if budget is None:
        budget = cost.Budget.from_environment()
    elif not isinstance(budget, cost.Budget):
        raise ParameterError(f"budget={budget!r} must be a synth.cost.Budget")
    options = {name: getattr(o, name) for name in cost.RENDER_OPTIONS}
    try:
        hash(scene)
    except TypeError:  # a field given as a list: not kept
        estimate = cost.estimate(scene, budget=budget, **options)
    else:
        estimate = _estimate(scene, budget, **options)
    estimate.check(budget)
    return estimate


@functools.lru_cache(maxsize=64)
def _estimate(scene, budget, **options) -> cost.CostEstimate:
    """:func:`synth.cost.estimate`, kept (every render of one scene asks for the same)."""
    return cost.estimate(scene, budget=budget, **options)


def _impacts(scene, o: RenderOptions, sequence) -> BounceSequence:
    """The drop's impacts (``sequence`` checked, or the scene's); an unsolved one is refused."""
    if sequence is None:
        sequence = simulate_scene(scene, **o.bounces())
    else:
        check_sequence(scene, sequence)
    for imp in sequence:
        if not imp.result.success:
            raise SynthError(
                f"impact {imp.index} (at {imp.speed:.4g} m/s) could not be solved: "
                f"{imp.result.message} The scene is outside what the contact solver handles"
            )
    return sequence


def _heard_modes(scene, o: RenderOptions, radiation_max_points=None) -> ModalModel:
    """The plate's modes heard by the scene's listener; a silent band is refused."""
    fs, f_max = o.samplerate, o.top_frequency
    points = radiation_max_points
    model = modal_model(
        scene.plate, scene.listener, samplerate=fs, max_frequency=f_max, radiation_max_points=points
    )
    if not model.poles.size:
        raise ParameterError(_silent_plate_message(f_max, fs, scene.plate, model.n_overdamped))
    return model


def _render_drop(
    scene, o: RenderOptions, sequence, model: ModalModel, contact_seconds: float = 0.0
) -> Render:
    """The drop's impacts through the modal bank, faded and levelled (``contact_seconds``:
    the wall time their contacts took, s)."""
    fs = o.samplerate
    excitation = model.excitation(scene.position)
    times = np.array([imp.time for imp in sequence])
    start = (times[0] + model.delay - o.preroll) if len(times) else 0.0
    weights = [scene.ball.mass * scene.gravity if imp.result.settled else 0.0 for imp in sequence]
    max_samples = int(math.ceil((sequence.duration + model.delay - start + o.max_tail) * fs))
    floor = 10.0 ** (o.floor_db / 20.0)
    audio, bank = synthesize(
        [imp.result for imp in sequence],
        times + model.delay - start,
        Bank(model.poles, excitation, model.output, fs),
        floor=floor,
        settled_weight=weights,
        direct=model.direct(excitation),
        max_samples=max_samples,
        pulse_points=o.pulse_points,
    )
    reference = bank["reference"]
    info = _info(
        scene, o, model, sequence,
        delay=model.delay,
        audio_start=start,
        n_modes_rendered=bank["n_modes_rendered"],
        mode_samples=bank["mode_samples"],
        tail_cut=bool(bank["length"] >= max_samples and bank["left_at_end"] > floor * reference),
        left_at_end=bank["left_at_end"] / reference if reference else 0.0,
        bank_seconds=bank["bank_seconds"],
        reference_amplitude=reference,
        contact_seconds=contact_seconds,
        transform_seconds=bank["transform_seconds"],
    )  # fmt: skip
    return _levelled(audio, o, model.units, sequence, info)


def _render_moving(scene, o: RenderOptions) -> Render:
    """:func:`render` of a scene with a horizontal velocity
    (:func:`synth.sound.rolling.render_path_audio`)."""
    from synth.sound.rolling import render_path_audio

    model = _heard_modes(scene, o)
    audio, path, figures = render_path_audio(scene, model, o)
    info = _info(scene, o, model, path.impacts, **figures)
    return _levelled(audio, o, model.units, path.impacts, info)


def _info(scene, o: RenderOptions, model: ModalModel, impacts, **figures) -> RenderInfo:
    """The :class:`RenderInfo` of a render, with the synthesis' ``figures``."""
    return RenderInfo(
        options=o.replace(max_frequency=o.top_frequency),
        listener=type(scene.listener).__name__.lower(),
        listener_position=tuple(scene.listener.position),
        n_impacts=len(impacts),
        stop_reason=impacts.stop_reason,
        n_modes=int(model.poles.size),
        n_modes_overdamped=model.n_overdamped,
        **figures,
    )


def _levelled(audio, o: RenderOptions, units: str, impacts, info: RenderInfo) -> Render:
    """The :class:`Render` of the physical signal ``audio`` (``units``), faded and levelled."""
    from synth.store import audio as audio_io

    _fade(audio, o.fade, o.samplerate)
    scaled, gain = audio_io.normalize(
        audio, o.normalize, samplerate=o.samplerate, units=units, peak_db=o.peak_db,
        loudness_lufs=o.loudness_lufs,
    )  # fmt: skip
    return Render(
        np.asarray(scaled, dtype=np.float32), o.samplerate, impacts, units, float(gain), info
    )


def _fade(audio, fade_s, fs) -> None:
    """A raised-cosine fade of ``fade_s`` s at the end of ``audio`` (in place)."""
    from synth.store import audio as audio_io

    if fade_s > audio.size / fs:
        raise ParameterError(
            f"fade={fade_s!r} s is longer than the audio "
            f"({audio.size / fs:.6g} s); it must be at most that"
        )
    if fade_s > 0 and audio.size:
        # the fade's n frames run from full level (the first) to 0 (the last)
        n = min(audio.size, int(round(fade_s * fs)))
        audio_io.apply_fade_out(audio, n - 1)


def _silent_plate_message(f_max: float, samplerate: int, plate=None, overdamped: int = 0) -> str:
    """Why a plate without a ringing mode below ``f_max`` (Hz) is refused, and what to change."""
    if overdamped:
        return (
            f"plate.material.damping={plate.material.damping!r} damps all {overdamped} modes "
            f"of the plate below {f_max:g} Hz past critical (they decay faster than they "
            f"ring), so the render would be silent; a solid's loss factor is below 1"
        )
    if f_max < 0.5 * samplerate:
        return (
            f"max_frequency={f_max!r} (Hz): no mode of the plate rings below it, so the "
            f"render would be silent; raise it (at most samplerate / 2 = {samplerate / 2:g} Hz)"
        )
    return (
        f"no mode of the plate rings below the Nyquist frequency samplerate / 2 = "
        f"{samplerate / 2:g} Hz, so the render would be silent; raise the samplerate (at "
        f"most {MAX_SAMPLERATE}) or use a larger, thinner or less stiff plate"
    )


#: Relative agreement of a passed sequence's first contact with the scene's own (the
#: solver's tolerance is far tighter; another ball or plate differs by percents).
SEQUENCE_RTOL = 1e-4


def check_sequence(scene, sequence) -> BounceSequence:
    """``sequence`` as the impacts of ``scene``: its first impact, solved again for the scene at
    the same speed, gives the same contact time and peak force within ``SEQUENCE_RTOL``. With the
    modal plate in the contact (an impact depends on the ringing before it) the first impact's
    contact law is checked instead."""
    from synth.physics import contact
    from synth.physics.plate_choice import scene_plate

    if not isinstance(sequence, BounceSequence):
        raise ParameterError(f"sequence={sequence!r} must be a BounceSequence")
    if not len(sequence):
        raise ParameterError("sequence has no impacts: there is nothing to render")
    if scene_plate(scene).plate == "modal":
        return _check_modal_sequence(scene, sequence)
    first, c = sequence[0], scene.contact
    own = contact.solve_impact(
        scene.ball,
        scene.plate,
        first.speed,
        position=scene.position,
        gravity=scene.gravity,
        contact=c.law,
        rtol=c.rtol,
        **c.options(),
    )
    for name in ("contact_time", "peak_force"):
        got, want = getattr(first.result, name), getattr(own, name)
        if not abs(got - want) <= SEQUENCE_RTOL * abs(want):
            raise ParameterError(
                f"sequence: its first impact's {name} {got:.6g} is not this scene's "
                f"({want:.6g} at {first.speed:.6g} m/s): the sequence belongs to another ball, "
                f"plate or contact law; pass the scene it was computed for"
            )
    return sequence


def _check_modal_sequence(scene, sequence) -> BounceSequence:
    """:func:`check_sequence` with the modal plate in the contact: the first impact is a
    :class:`~synth.physics.modal_contact.ModalImpactResult` of the scene's contact law."""
    from synth.physics.contact_law import contact_parameters
    from synth.physics.modal_contact import ModalImpactResult

    c = scene.contact
    result = sequence[0].result
    law = contact_parameters(scene.ball, scene.plate, c.law, **c.options())
    want = (law.stiffness, law.exponent, law.dissipation, law.viscous_time)
    fields = ("stiffness", "exponent", "dissipation", "viscous_time")
    if not isinstance(result, ModalImpactResult) or not all(
        abs(getattr(result, f"law_{name}") - b) <= SEQUENCE_RTOL * abs(b)
        for name, b in zip(fields, want)
    ):
        K, n, mu, A = want
        raise ParameterError(
            "sequence: its first impact is not one of this scene's modal contact (contact law "
            f"K, n, mu, A = {K:.6g}, {n:g}, {mu:g}, {A:g}): the sequence belongs to another "
            "ball, plate or contact law; pass the scene it was computed for"
        )
    return sequence
