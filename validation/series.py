"""The rows of the end of a series (e below 0.2 m/s, the ringing left by earlier impacts,
the air film and adhesion) and of the tick decay's definition (Chapter 5)."""

from __future__ import annotations

import math

import numpy as np

from synth.errors import ParameterError
from validation.modal import LATE_SPEED_BINS
from validation.rows import (
    DECAY_SMOOTHING,
    THESIS_TICK_DECAY,
    envelope_decay_time,
    smoothed_envelope,
    thesis_row,
)

#: Silence before the first tick of the series' render (s).
RENDER_PREROLL = 0.005
#: Band of the plate's low modes (Hz): those still ringing 250 ms after an impact in the
#: thesis' recordings (Chapter 5), the ones its section 3.5.1 (item 6) points at.
LOW_MODE_BAND = 500.0
#: The band above it that carries most of the ringing at touch late in a series (Hz).
MID_MODE_BAND = (500.0, 2000.0)
#: Smoothing windows (s) of the envelope for the tick decay "peak to 37 %": the thesis
#: names no window; 0.5 ms is the rows above, the others run from about the time the
#: edges' reflections take to come back (2 ms) to 10 ms.
TICK_DECAY_SMOOTHING = (2e-3, 5e-3, 10e-3)
#: Dynamic viscosity of air at 20 C (Pa s; Kaye & Laby) and the gap (m) at which the air
#: film between ball and board stops (an upper bound of the loss: the roughness of an MDF
#: surface is a few um).
AIR_VISCOSITY = 1.81e-5
AIR_FILM_CUTOFF = 1e-6
#: Upper bound of the work of adhesion of two dry solids in air (J/m^2; van der Waals,
#: Israelachvili, Intermolecular and Surface Forces, 3rd ed. 2011, chapter 13: 0.04-0.1).
WORK_OF_ADHESION = 0.1


def air_film_loss(ball, speed: float) -> float:
    """``1 - e`` (dimensionless, first order) that the air squeezed between the ball and a
    flat board takes at ``speed`` (m/s): Reynolds' lubrication force on a sphere near a
    plane, ``F = 6 pi eta R^2 v / h`` (Brenner 1961), integrated from ``h = R`` down to
    :data:`AIR_FILM_CUTOFF` on the way in and back on the way out at the impact speed (an
    upper bound: the flow slips below the air's mean free path, 68 nm). Lost energy over
    ``m v^2``: it grows as ``1 / v``."""
    r = ball.radius
    work = 2.0 * 6.0 * math.pi * AIR_VISCOSITY * r * r * speed * math.log(r / AIR_FILM_CUTOFF)
    return work / (ball.mass * speed * speed)


def adhesion_loss(ball, speed: float, modulus: float) -> float:
    """``1 - e`` (dimensionless, first order) of the adhesion hysteresis of a JKR contact
    (Johnson, Kendall & Roberts 1971) at ``speed`` (m/s), bounded by the pull-off force
    ``1.5 pi w R`` times the pull-off approach ``(3/4) (pi^2 w^2 R / E*^2)^(1/3)`` with
    ``w`` = :data:`WORK_OF_ADHESION` and ``E*`` = ``modulus`` (Pa, the contact's): a fixed
    energy per impact, so ``1 - e`` grows as ``1 / v^2``."""
    r, w = ball.radius, WORK_OF_ADHESION
    energy = 1.5 * math.pi * w * r * 0.75 * (math.pi**2 * w * w * r / modulus**2) ** (1.0 / 3.0)
    return energy / (ball.mass * speed * speed)


def thesis_lowspeed_rows(samplerate: int = 48000) -> list:
    """The rows of the end of a series and of the tick decay's definition, for the fitted
    model (``contact.model = "fitted"``; 10 mm steel on the middle of the 18 mm board, 10 cm
    drop, the default scene's microphone 20 cm above the impact, rendered at
    ``samplerate``, Hz).

    End of a series (thesis 3.5: e falls as the speed falls below 0.2 m/s), per speed bin
    of :data:`LATE_SPEED_BINS`: the restitution as the thesis measured it, from bounce
    times, both from the scheduler's onsets and from the ticks the analysis
    (:func:`synth.analysis.analyze`) finds in the render; the ringing left by earlier
    impacts (thesis 3.5.1, item 6): the plate's velocity under the ball at touch over the
    impact speed (RMS), the same of the modes below :data:`LOW_MODE_BAND` alone and of
    those in :data:`MID_MODE_BAND` alone, and the mean change of e it makes (each impact
    solved again on a plate at rest); and the losses of the air film and of adhesion (closed-form bounds,
    :func:`air_film_loss`, :func:`adhesion_loss`) at the bin's lower speed.

    Tick decay (Chapter 5: 11, 12.3, 14 ms for ticks 1, 6, 8): envelope from its peak to
    37 % smoothed over each of :data:`TICK_DECAY_SMOOTHING`, in the rendered series (the
    earlier ticks' tails under each tick) and, at 5 ms, each tick rendered alone; and the
    analysis' own decay time (a log-linear fit of the tick's own sound's envelope)."""
    from synth.analysis import analyze
    from synth.io.presets import load_preset
    from synth.physics.bounces import simulate_scene
    from synth.sound.render import render

    scene = load_preset("default", ["contact.model=fitted"])
    seq = simulate_scene(scene)
    audio = render(
        scene, samplerate=samplerate, normalize="none", sequence=seq, preroll=RENDER_PREROLL
    )
    x = audio.audio.astype(float)
    found = analyze(x, samplerate, gravity=seq.gravity)
    rows = _lowspeed_restitution_rows(scene, seq, found)
    rows += _tick_decay_definition_rows(scene, seq, x, samplerate, found)
    return rows


def _bin_mean(values, speeds, lo: float, hi: float) -> float:
    """Mean of ``values`` whose speed (m/s) is in ``[lo, hi)``; nan when none is."""
    v = [x for x, s in zip(values, speeds, strict=True) if lo <= s < hi]
    return float(np.mean(v)) if v else float("nan")


def _lowspeed_restitution_rows(scene, seq, found) -> list:
    """The end-of-series rows of :func:`thesis_lowspeed_rows`: ``seq`` the fitted model's
    series of ``scene``, ``found`` the analysis of its render."""
    from synth.physics import modal_contact as mc
    from synth.physics.contact_law import contact_parameters

    c = scene.contact
    contact = mc.ModalContact.for_pair(
        scene.ball,
        scene.plate,
        scene.position,
        gravity=scene.gravity,
        law=c.law,
        speed=seq[0].speed,
        theory=c.theory,
        **c.options(),
    )
    f = contact.point.omega / (2.0 * math.pi)
    low = f < LOW_MODE_BAND
    mid = (f >= MID_MODE_BAND[0]) & (f < MID_MODE_BAND[1])
    speeds = [i.speed for i in seq]
    e = [i.restitution for i in seq]
    timed = bounce_time_restitution(seq)
    # the analysis' e_n (tick n + 1) against the impact speed of tick n, g t_(n-1) / 2
    ticks = found.ticks
    heard = [t.restitution for t in ticks[2:]]
    heard_speeds = [t.speed for t in ticks[1:-1]]
    ring = [i.plate_velocity / i.speed for i in seq]
    # the band's modes only: the state holds the residual's lumped modes after them
    band = [i.plate_state.v[: i.plate_state.n_band] for i in seq]
    ring_low = [float(v[low].sum()) / i.speed for v, i in zip(band, seq, strict=True)]
    ring_mid = [float(v[mid].sum()) / i.speed for v, i in zip(band, seq, strict=True)]
    K = contact_parameters(scene.ball, scene.plate, c.law, **c.options()).stiffness
    modulus = 0.75 * K / math.sqrt(scene.ball.radius)
    note = "measured: e falls as the speed falls below 0.2 m/s (thesis 3.5)"
    rows = []
    for lo, hi in LATE_SPEED_BINS:
        inside = [k for k, v in enumerate(speeds) if lo <= v < hi]
        at_rest = [contact.solve(speeds[k]).restitution for k in inside]
        change = float(np.mean([e[k] - r for k, r in zip(inside, at_rest, strict=True)]))
        rms = math.sqrt(float(np.mean([ring[k] ** 2 for k in inside])))
        low_rms = math.sqrt(float(np.mean([ring_low[k] ** 2 for k in inside])))
        mid_rms = math.sqrt(float(np.mean([ring_mid[k] ** 2 for k in inside])))
        span = f"{lo:g}-{hi:g} m/s"
        rows += [
            thesis_row(
                f"restitution at {span}, fitted model, from the onsets' bounce times "
                "e_n = t_n / t_(n-1)",
                "",
                _bin_mean(timed, speeds[1:-1], lo, hi),
                _bin_mean(e, speeds, lo, hi),
                None,
                "model: the same impacts' rebound over impact speed; " + note,
            ),
            thesis_row(
                f"restitution at {span}, fitted model, from the ticks the analysis finds "
                "at the microphone",
                "",
                _bin_mean(heard, heard_speeds, lo, hi),
                _bin_mean(e, speeds, lo, hi),
                None,
                "binned by the analysis' own impact speed g t_(n-1) / 2; " + note,
            ),
            thesis_row(
                f"plate velocity under the ball at touch over impact speed, RMS, {span}",
                "-",
                rms,
                None,
                None,
                "the ringing left by earlier impacts (thesis 3.5.1, item 6)",
            ),
            thesis_row(
                f"the same, modes below {LOW_MODE_BAND:g} Hz only, RMS, {span}",
                "-",
                low_rms,
                None,
                None,
                "the modes still ringing 250 ms after an impact in the thesis' recordings",
            ),
            thesis_row(
                f"the same, modes of {MID_MODE_BAND[0]:g}-{MID_MODE_BAND[1]:g} Hz only, RMS, "
                f"{span}",
                "-",
                mid_rms,
                None,
                None,
                "the band that carries most of the ringing at touch late in a series",
            ),
            thesis_row(
                f"mean change of e by the ringing (e minus e on a plate at rest), {span}",
                "-",
                change,
                None,
                None,
                "each impact of the bin solved again at its speed on a plate at rest",
            ),
            thesis_row(
                f"loss 1 - e of the air film between ball and board at {lo:g} m/s",
                "-",
                air_film_loss(scene.ball, lo),
                None,
                None,
                "Reynolds lubrication, an upper bound; grows as 1 / v",
            ),
            thesis_row(
                f"loss 1 - e of adhesion (JKR hysteresis) at {lo:g} m/s",
                "-",
                adhesion_loss(scene.ball, lo, modulus),
                None,
                None,
                f"work of adhesion {WORK_OF_ADHESION:g} J/m^2, an upper bound; grows as 1 / v^2",
            ),
        ]
    return rows


def _tick_decay_definition_rows(scene, seq, x, fs: int, found) -> list:
    """The tick decay rows of :func:`thesis_lowspeed_rows`: ``x`` the render of ``seq``
    (Pa at ``fs``, Hz, the first touch :data:`RENDER_PREROLL` after its start), ``found``
    its analysis."""
    from synth.physics.bounces import BounceSequence
    from synth.sound.render import render

    onsets = [int(round((i.time - seq[0].time + RENDER_PREROLL) * fs)) for i in seq]
    onsets.append(x.size)
    rows = []
    for smooth in TICK_DECAY_SMOOTHING:
        for n, measured in THESIS_TICK_DECAY.items():
            rows.append(
                thesis_row(
                    f"tick {n} decay, envelope peak to 37 % smoothed over {smooth * 1e3:g} ms, "
                    "in the series, fitted model",
                    "s",
                    envelope_decay_time(x, fs, smooth, onsets[n - 1], onsets[n]),
                    None,
                    measured,
                    "moving average of the Hilbert envelope",
                )
            )
    for n, measured in THESIS_TICK_DECAY.items():
        alone = BounceSequence(seq.impacts[n - 1 : n], "max-impacts", seq.drop_height, seq.gravity)
        y = render(scene, samplerate=fs, normalize="none", sequence=alone).audio.astype(float)
        rows.append(
            thesis_row(
                f"tick {n} decay, envelope peak to 37 % smoothed over 5 ms, tick alone, "
                "fitted model",
                "s",
                envelope_decay_time(y, fs, 5e-3),
                None,
                measured,
                "the earlier ticks' tails left out",
            )
        )
    rows += _microphone_rows(scene, seq, fs)
    for n, measured in THESIS_TICK_DECAY.items():
        rows.append(
            thesis_row(
                f"tick {n} decay, the analysis' fit of its own sound's envelope, fitted model",
                "s",
                found.ticks[n - 1].decay_time,
                None,
                measured,
                "log-linear fit from the peak, RMS envelope over 2 ms (docs/analysis.md)",
            )
        )
    return rows


#: Where the direct pulse stops ruling the envelope (s after its peak): the reflections
#: from the board's long edges (24.5 cm away) are back by about 1 ms at the group velocity
#: of 2-3 kHz, the short edges' by about 2 ms.
DIRECT_PULSE_SPAN = 3e-3


def _microphone_rows(scene, seq, fs: int) -> list:
    """Tick 1 alone at the default microphone (20 cm above the impact) and at 20 cm from the
    impact at 45 degrees along the board's length: the peak of the 0.5 ms envelope over
    its level :data:`DIRECT_PULSE_SPAN` later (the direct pulse against the whole plate's
    ringing), and at the second the decay, peak to 37 %, smoothed over 0.5 and 2 ms (the
    first's are the rows of :func:`thesis_lowspeed_rows` and :func:`thesis_modal_rows`)."""
    from dataclasses import replace

    from synth.physics.bounces import BounceSequence
    from synth.physics.scene import Microphone
    from synth.sound.render import render

    x0, y0 = scene.position
    h = 0.2 / math.sqrt(2.0)
    first = BounceSequence(seq.impacts[:1], "max-impacts", seq.drop_height, seq.gravity)
    rows = []
    for where, mic in (
        ("20 cm above the impact", scene.listener),
        ("20 cm from the impact at 45 degrees", Microphone((x0 + h, y0, h))),
    ):
        y = render(replace(scene, listener=mic), samplerate=fs, normalize="none", sequence=first)
        y = y.audio.astype(float)
        env = smoothed_envelope(y, fs, DECAY_SMOOTHING)
        k = int(np.argmax(env))
        rows.append(
            thesis_row(
                f"tick 1 at {where}: peak of the 0.5 ms envelope over its level "
                f"{DIRECT_PULSE_SPAN * 1e3:g} ms later (dB), fitted model",
                "-",
                20.0 * math.log10(env[k] / env[k + int(DIRECT_PULSE_SPAN * fs)]),
                None,
                None,
                "the direct pulse near the impact point against the whole plate's ringing",
            )
        )
        for smooth in (DECAY_SMOOTHING, 2e-3) if mic is not scene.listener else ():
            rows.append(
                thesis_row(
                    f"tick 1 decay at {where}, envelope peak to 37 % smoothed over "
                    f"{smooth * 1e3:g} ms, fitted model",
                    "s",
                    envelope_decay_time(y, fs, smooth),
                    None,
                    THESIS_TICK_DECAY[1],
                    "tick alone",
                )
            )
    return rows


def bounce_time_restitution(seq) -> list[float]:
    """The restitution as the thesis measures it from bounce times (section 3.1), ``e_n = t_n /
    t_(n-1)``, impacts 2 to N - 1; contact times raise it by about ``(tau_n / e - tau_(n-1)) /
    t_(n-1)`` (docs/analysis.md)."""
    from synth.physics.bounces import BounceSequence

    if not isinstance(seq, BounceSequence):
        raise ParameterError(f"seq={seq!r} must be a BounceSequence")
    t = [i.time for i in seq]
    return [(t[k + 1] - t[k]) / (t[k] - t[k - 1]) for k in range(1, len(t) - 1)]
