"""``synth bench analysis --random N --seed S``: the analysis on the engine's own renders of
random scenes, scored against the impacts the engine's scheduler made.

Each scene draws a ball, a plate (thin or thick, lightly damped metal and glass among the
materials), an impact point (half of them near an edge), a listener (an off-axis microphone
or an accelerometer) and a sample rate (44.1-96 kHz). The render is analysed with the
analysis' defaults and each detected tick matched to the nearest true onset.

Scores, per scene and in total:

* false ticks: detected ticks that match no true impact;
* impossible values: ticks whose reported values contradict physics or the scene's truth
  (:func:`impossible_value`): a non-finite measurement, a restitution not above 0, an
  impact speed above the drop's free-fall speed, a restitution of 1 or more (growth of the
  bounce time) where the true impacts its ticks match show no growth, or a restitution
  reported with a flag that says it is no bounce's. A ratio above 1 is a possible value: a
  vibrating plate can give the ball energy back, and the engine's own flights then grow;
* audible impacts missed: true impacts that are audible (:func:`impact_audibility`) and
  that no detected tick matches, each listed with its margin over the ringing and the bounce
  before it (a miss in a fast chatter or a weak one at the edge of audibility reads apart
  from a clear tick missed);
* seconds of analysis per second of audio.
"""

from __future__ import annotations

import functools
import math
import sys
import time
from dataclasses import asdict, dataclass

import numpy as np

#: A detected tick matches a true impact when its onset lies within this of the impact's
#: onset, s, or within the impact's contact time when that is longer (a soft ball's tick
#: rises over its contact).
MATCH_TOLERANCE = 1e-3
#: A measured onset may lie this many sample periods from the true one without contradicting
#: it when a restitution is judged against the true ratio (sub-sample onsets; the analysis'
#: own searches agree within two sample periods).
ONSET_SLACK = 2.0
#: An impact is audible when its own sound, over its window, has at least this much energy
#: relative to all the other impacts' sound (the ringing) in the same window, dB: a tick
#: that does not stand as loud as the ringing around it is masked (tick-to-masker ratio,
#: as in tests/test_roundtrip.py).
AUDIBLE_TMR_DB = 0.0
#: ... and when its own peak is within this of the recording's peak, dB: the dynamic range
#: of a listening level (an impact 60 dB under the loudest is below the noise of a room).
AUDIBLE_RANGE_DB = 60.0
#: The window of an impact's own sound for audibility: to the next impact's onset, at most
#: this long, s.
AUDIBLE_WINDOW = 0.02

#: How a scene's render ended (:attr:`SceneScore.render`): scored; refused by the engine
#: (``ParameterError``: a scene outside what it renders, by design); or failed (any other
#: ``SynthError``: the engine could not render a scene it accepts).
SCORED, REFUSED, RENDER_FAILED = "scored", "refused", "render failed"

_BALLS = ("steel", "glass", "rubber", "aluminium", "brass", "porcelain")
_PLATES = (
    "aluminium",
    "steel",
    "glass",
    "brass",
    "copper",
    "oak",
    "plywood",
    "mdf-18",
    "acrylic",
    "polycarbonate",
    "granite",
)
_BOUNDARIES = ("free", "simply-supported", "clamped")
_RATES = (44100, 48000, 88200, 96000)


@dataclass(frozen=True)
class SceneSpec:
    """One random scene (SI units): ball material and radius (m), plate material, thickness,
    length and width (m) and boundary, drop height (m) and point (m from a corner),
    listener kind and position (m; microphone: x, y and height above the plate), sample
    rate (Hz), the latest impact from the release (s) and the longest ringing after the
    last impact (s)."""

    ball: str
    radius: float
    plate: str
    thickness: float
    length: float
    width: float
    boundary: str
    height: float
    position: tuple[float, float]
    listener: str
    listener_position: tuple
    samplerate: int
    duration: float
    tail: float

    def describe(self) -> str:
        """One line: the scene as a reader pictures it."""
        where = "mic" if self.listener == "microphone" else "accelerometer"
        return (
            f"{self.radius * 2e3:.0f} mm {self.ball} ball, {self.height * 100:.0f} cm on "
            f"{self.thickness * 1e3:.1f} mm {self.plate} {self.length:.2f}x{self.width:.2f} m "
            f"{self.boundary}, {where}, {self.samplerate / 1000:g} kHz"
        )


def random_specs(count: int, seed: int) -> list[SceneSpec]:
    """``count`` random scenes drawn by ``seed``: ball 3-15 mm radius dropped 2-30 cm; plate
    1-40 mm thick (log-uniform), sides 0.2-1.2 m; the impact point uniform over the plate, or
    (half the scenes) within 4 % of a side from an edge; a microphone 0.1-1 m above a point
    anywhere over the plate (off-axis) or an accelerometer anywhere on it; 44.1-96 kHz; impacts up to 1-8 s
    after the release and 1-4 s of ringing after the last one at most."""
    rng = np.random.default_rng(seed)
    return [_random_spec(rng) for _ in range(count)]


def _random_spec(rng) -> SceneSpec:
    a, b = (float(v) for v in rng.uniform(0.2, 1.2, 2))
    if rng.random() < 0.5:
        frac = np.array([rng.uniform(0.02, 0.04), rng.uniform(0.05, 0.95)])
        if rng.random() < 0.5:
            frac = 1.0 - frac
        if rng.random() < 0.5:
            frac = frac[::-1]
    else:
        frac = rng.uniform(0.05, 0.95, 2)
    if rng.random() < 0.7:
        listener = "microphone"
        where = (float(rng.uniform(0, a)), float(rng.uniform(0, b)), float(rng.uniform(0.1, 1.0)))
    else:
        listener = "accelerometer"
        where = (float(rng.uniform(0.05, 0.95) * a), float(rng.uniform(0.05, 0.95) * b))
    return SceneSpec(
        ball=_BALLS[int(rng.integers(len(_BALLS)))],
        radius=float(rng.uniform(0.003, 0.015)),
        plate=_PLATES[int(rng.integers(len(_PLATES)))],
        thickness=float(math.exp(rng.uniform(math.log(0.001), math.log(0.04)))),
        length=a,
        width=b,
        boundary=_BOUNDARIES[int(rng.integers(len(_BOUNDARIES)))],
        height=float(rng.uniform(0.02, 0.3)),
        position=(float(frac[0] * a), float(frac[1] * b)),
        listener=listener,
        listener_position=where,
        samplerate=int(_RATES[int(rng.integers(len(_RATES)))]),
        duration=float(rng.uniform(1.0, 8.0)),
        tail=float(rng.uniform(1.0, 4.0)),
    )


def build_scene(spec: SceneSpec):
    """The :class:`~synth.physics.scene.Scene` of ``spec`` (the default contact model)."""
    from synth.physics.scene import Accelerometer, Ball, Microphone, Plate, Scene

    listener = (
        Microphone(spec.listener_position)
        if spec.listener == "microphone"
        else Accelerometer(spec.listener_position)
    )
    return Scene(
        Ball(spec.ball, spec.radius),
        Plate(spec.plate, spec.thickness, spec.length, spec.width, spec.boundary),
        drop_height=spec.height,
        position=spec.position,
        listener=listener,
    )


@dataclass(frozen=True)
class Truth:
    """A render and what the engine knows of it: the audio (signal units), its sample rate
    (Hz), each impact's onset in the audio (s), contact time (s), whether it is audible, the
    drop's free-fall speed (m/s), and each impact's margin over the ringing (dB,
    :class:`Audibility`; None where not worked out)."""

    audio: np.ndarray
    samplerate: int
    onsets: np.ndarray
    contact_times: np.ndarray
    audible: np.ndarray
    fall_speed: float
    margins: np.ndarray | None = None


def render_truth(spec: SceneSpec) -> Truth:
    """Render ``spec`` (no normalisation) and mark its audible impacts
    (:func:`impact_audibility`)."""
    from synth.physics.bounces import simulate_scene
    from synth.sound.render import render

    scene = build_scene(spec)
    seq = simulate_scene(scene, max_duration=spec.duration)
    r = render(
        scene,
        samplerate=spec.samplerate,
        normalize="none",
        sequence=seq,
        max_duration=spec.duration,
        max_tail=spec.tail,
    )
    audio = np.asarray(r.audio, dtype=float)
    heard = impact_audibility(scene, seq, r, audio)
    return Truth(
        audio=audio,
        samplerate=r.samplerate,
        onsets=np.asarray(r.onsets, dtype=float),
        contact_times=np.array([imp.result.contact_time for imp in seq]),
        audible=heard.audible,
        fall_speed=math.sqrt(2.0 * seq.gravity * seq.drop_height),
        margins=heard.margin_db,
    )


@dataclass(frozen=True)
class Audibility:
    """Each impact's margin over the ringing, dB: its own sound's energy over its window
    against all the other impacts' there (-inf where the window is empty), and whether its
    own peak lies within :data:`AUDIBLE_RANGE_DB` of the recording's."""

    margin_db: np.ndarray
    loud: np.ndarray

    @property
    def audible(self) -> np.ndarray:
        """Loud enough, and at least :data:`AUDIBLE_TMR_DB` over the ringing."""
        return self.loud & (self.margin_db >= AUDIBLE_TMR_DB)


def impact_audibility(scene, seq, r, audio: np.ndarray) -> Audibility:
    """Whether each impact of the render ``r`` is audible: its own sound (the impact rendered
    alone on the same timeline; the synthesis is linear in the impacts) over its window (to
    the next onset, at most :data:`AUDIBLE_WINDOW`) holds at least :data:`AUDIBLE_TMR_DB`
    more energy than all the other impacts' sound there, and its own peak lies within
    :data:`AUDIBLE_RANGE_DB` of the recording's."""
    from synth.physics.bounces import BounceSequence
    from synth.sound.render import render

    fs = r.samplerate
    onsets = np.asarray(r.onsets)
    top = float(np.max(np.abs(audio)))
    margin = np.full(len(seq), -np.inf)
    loud = np.zeros(len(seq), dtype=bool)
    for i, imp in enumerate(seq):
        # the impact alone, from a whole sample `shift` before its onset in the render: its
        # sample j is the render's sample j + shift, to the same sub-sample place
        shift = max(0, int(math.floor(onsets[i] * fs)) - 8)
        alone = render(
            scene,
            samplerate=fs,
            max_tail=AUDIBLE_WINDOW,
            normalize="none",
            preroll=float(onsets[i] - shift / fs),
            fade=0.0,
            sequence=BounceSequence((imp,), seq.stop_reason, seq.drop_height, seq.gravity),
        ).audio.astype(float)
        a = int(round(onsets[i] * fs))
        b = a + int(AUDIBLE_WINDOW * fs)
        if i + 1 < len(seq):
            b = min(b, int(round(onsets[i + 1] * fs)))
        b = min(b, alone.size + shift, audio.size)
        if b <= a:
            continue
        own_part = alone[a - shift : b - shift]
        own = float(np.sum(own_part**2))
        other = float(np.sum((audio[a:b] - own_part) ** 2))
        loud[i] = np.max(np.abs(own_part)) >= top * 10.0 ** (-AUDIBLE_RANGE_DB / 20.0)
        with np.errstate(divide="ignore"):
            margin[i] = 10.0 * math.log10(own / other) if other > 0.0 else np.inf
    return Audibility(margin, loud)


@dataclass(frozen=True)
class SceneScore:
    """The analysis of one scene against its truth: impacts (all, audible), ticks reported,
    false ticks, impossible values, audible impacts missed, audio length (s), analysis time
    (s), the error raised instead of a result (None), each fault, in words, and how the
    render ended (:data:`SCORED`, :data:`REFUSED` or :data:`RENDER_FAILED`)."""

    scene: str
    impacts: int
    audible: int
    ticks: int
    false_ticks: int
    impossible: int
    missed: int
    duration: float
    seconds: float
    error: str | None = None
    faults: tuple[str, ...] = ()
    render: str = SCORED


def score(truth: Truth, ticks: list) -> tuple[int, int, int]:
    """False ticks, impossible values and audible impacts missed of ``ticks`` (the analysis'
    :class:`~synth.analysis.report.Tick` list, in time order) against ``truth``."""
    false, impossible, missed = faults(truth, ticks)
    return len(false), len(impossible), len(missed)


def faults(truth: Truth, ticks: list) -> tuple[list, list, list]:
    """The false ticks and the ticks of impossible values of ``ticks`` (lists of
    :class:`~synth.analysis.report.Tick`) and the onsets of the audible impacts missed (s),
    against ``truth`` (:func:`score`)."""
    tol = np.maximum(MATCH_TOLERANCE, truth.contact_times)
    matched = np.zeros(truth.onsets.size, dtype=bool)
    match = []  # the true impact of each tick, -1 for a false tick
    for t in ticks:
        d = np.abs(truth.onsets - t.time)
        free = np.where(~matched & (d <= tol))[0]
        if free.size:
            k = int(free[np.argmin(d[free])])
            matched[k] = True
            match.append(k)
        else:
            match.append(-1)
    impossible = [
        t for n, t in enumerate(ticks) if impossible_value(t, truth, match[max(0, n - 3) : n + 1])
    ]
    false = [t for t, k in zip(ticks, match) if k < 0]
    return false, impossible, list(truth.onsets[truth.audible & ~matched])


def _unique(ticks: list) -> list:
    """``ticks`` in their order, each once (a false tick may report an impossible value)."""
    return [t for n, t in enumerate(ticks) if not any(t is u for u in ticks[:n])]


def _fault_line(t, false: bool, impossible: bool) -> str:
    """One line naming a faulty tick: false, impossible (with what it reports), or both."""
    kinds = ["false"] * false + [f"impossible (e {t.restitution}, flags {t.flags})"] * impossible
    return f"{' and '.join(kinds)} tick at {t.time:.5f} s"


def impossible_value(t, truth: Truth, impacts: list) -> bool:
    """Whether the tick ``t`` reports a value that contradicts physics or ``truth``.

    ``impacts`` are the true impacts (indices, -1 for a false tick) that ``t`` and the up to
    three ticks before it match; its restitution ``e_n = t_n / t_(n-1)`` is measured from the
    last three. Physics: every measurement finite, ``e_n > 0``, the impact speed at most the
    drop's free-fall speed (1 % over it allowed: the bounce time holds the contact time too).
    Truth: ``e_n >= 1`` only where the true onsets of those impacts allow a ratio of 1 or
    more (:func:`_growth_allowed`; with a false tick among them no bounce grew). A
    restitution reported together with a flag of
    :data:`~synth.analysis.report.RESTITUTION_FLAGS` is one the analysis itself says is no
    bounce's: impossible. A flag on a tick that reports no restitution is a reason, not a
    value."""
    from synth.analysis.report import RESTITUTION_FLAGS

    values = (t.time, t.energy, t.peak, t.centroid, t.spread)
    if not all(math.isfinite(v) for v in values):
        return True
    if t.speed is not None and not t.speed <= 1.01 * truth.fall_speed:
        return True
    if t.restitution is None:
        return False
    if set(t.flags) & set(RESTITUTION_FLAGS):
        return True
    if not (math.isfinite(t.restitution) and t.restitution > 0.0):
        return True
    return t.restitution >= 1.0 and not _growth_allowed(truth, impacts[-3:])


def _growth_allowed(truth: Truth, impacts: list) -> bool:
    """Whether the true impacts ``impacts`` (three, in order, none false) allow a bounce-time
    ratio of 1 or more, each onset moved by :data:`ONSET_SLACK` sample periods."""
    if len(impacts) < 3 or min(impacts) < 0:
        return False
    on = truth.onsets[impacts]
    slack = ONSET_SLACK / truth.samplerate
    return bool(on[2] - on[1] + 2.0 * slack >= on[1] - on[0] - 2.0 * slack)


def _analysis_child(audio: np.ndarray, samplerate: int, conn) -> None:
    """Analyse ``audio`` with the defaults and send ``(ticks, error, seconds)`` on ``conn``."""
    conn.send(timed_analysis(audio, samplerate, None))
    conn.close()


@functools.cache
def warm_analysis() -> None:
    """Analyse a short synthetic bounce once in this process, untimed: the analysis' first
    call imports its lazy modules (scipy.signal) and loads its compiled kernels, seconds of
    work that a process analysing many recordings pays once and that is no part of the time
    per second of audio; a child forked afterwards inherits them."""
    from benchmarks.analysis import synthetic_bounce
    from synth.analysis import analyze

    x, fs, _ = synthetic_bounce(0.8, 48000, snr_db=40.0)
    analyze(x, fs)


def timed_analysis(audio: np.ndarray, samplerate: int, limit: float | None):
    """The analysis of ``audio`` (defaults): ``(ticks, error, seconds)``; with ``limit`` (s),
    in a child process stopped after that long (error ``"stopped after ... s"``). The
    process is warmed first (:func:`warm_analysis`), so the time is the analysis' own."""
    warm_analysis()
    if limit is None:
        from synth.analysis import AnalysisError, analyze

        t0 = time.perf_counter()
        try:
            return analyze(audio, samplerate).ticks, None, time.perf_counter() - t0
        except AnalysisError as exc:
            return [], str(exc), time.perf_counter() - t0
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    here, there = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_analysis_child, args=(audio, samplerate, there), daemon=True)
    child.start()
    there.close()
    try:
        if here.poll(limit):
            return here.recv()
        return [], f"stopped after {limit:g} s", limit
    finally:
        if child.is_alive():
            child.kill()
        child.join()
        here.close()


def run_scene(spec: SceneSpec, limit: float | None = None) -> SceneScore:
    """Render ``spec``, analyse it with the defaults (timed; stopped after ``limit`` s when
    given) and score it. A scene the engine refuses to render (``ParameterError``: the ball
    comes to rest on the plate within the render) or fails to render (another
    ``SynthError``) scores nothing, with the reason: the other scenes are scored still."""
    from synth.errors import ParameterError, SynthError

    try:
        truth = render_truth(spec)
    except ParameterError as exc:
        return _unrendered(spec, REFUSED, f"not rendered: {exc}")
    except SynthError as exc:
        return _unrendered(spec, RENDER_FAILED, f"{RENDER_FAILED}: {exc}")
    duration = truth.audio.size / truth.samplerate
    ticks, error, seconds = timed_analysis(truth.audio, truth.samplerate, limit)
    false, impossible, missed = faults(truth, ticks)
    listed = [_fault_line(t, t in false, t in impossible) for t in _unique(false + impossible)]
    if missed:
        listed.append(f"audible impacts missed at {np.round(missed, 5).tolist()} s")
        listed.append(missed_detail(truth, missed))
    return SceneScore(
        scene=spec.describe(),
        impacts=int(truth.onsets.size),
        audible=int(np.count_nonzero(truth.audible)),
        ticks=len(ticks),
        false_ticks=len(false),
        impossible=len(impossible),
        missed=len(missed),
        duration=duration,
        seconds=seconds,
        error=error,
        faults=tuple(listed),
    )


def _unrendered(spec: SceneSpec, render: str, error: str) -> SceneScore:
    """The row of a scene with no render to score: ``render`` says why, ``error`` in words."""
    return SceneScore(spec.describe(), 0, 0, 0, 0, 0, 0, 0.0, 0.0, error, render=render)


def missed_detail(truth: Truth, missed: list) -> str:
    """The missed impacts' margins over the ringing (dB) and the bounces before them (ms,
    none for the first impact), in the order of ``missed``: a fast chatter's misses, a few
    milliseconds apart, read apart from isolated ones, and marginal ones from clear ones."""
    k = np.searchsorted(truth.onsets, missed)
    gaps = [
        None if i == 0 else round(float(truth.onsets[i] - truth.onsets[i - 1]) * 1e3, 2) for i in k
    ]
    margins = "?" if truth.margins is None else np.round(truth.margins[k], 1).tolist()
    return f"their margins over the ringing {margins} dB, bounces before them {gaps} ms"


def run_random(count: int, seed: int, limit: float | None = None) -> dict:
    """:func:`run_scene` over ``count`` scenes of :func:`random_specs` (``seed``), each
    analysis stopped after ``limit`` s when given, and the totals (scenes refused and
    renders failed counted apart)."""
    rows = []
    for i, spec in enumerate(random_specs(count, seed), 1):
        rows.append(asdict(run_scene(spec, limit)))
        r = rows[-1]
        print(  # progress: a run of 30 scenes takes minutes
            f"scene {i}/{count}: {r['scene']}: {r['ticks']} ticks, {r['false_ticks']} false, "
            f"{r['impossible']} impossible, {r['missed']} of {r['audible']} audible missed, "
            f"{_per_second(r):.3f} s/s{'' if r['error'] is None else ' (' + r['error'] + ')'}",
            file=sys.stderr,
            flush=True,
        )
        for line in r["faults"]:
            print(f"  {line}", file=sys.stderr, flush=True)
    total_audio = sum(r["duration"] for r in rows)
    total_time = sum(r["seconds"] for r in rows)
    return dict(
        seed=seed,
        rows=rows,
        false_ticks=sum(r["false_ticks"] for r in rows),
        impossible=sum(r["impossible"] for r in rows),
        missed=sum(r["missed"] for r in rows),
        audible=sum(r["audible"] for r in rows),
        impacts=sum(r["impacts"] for r in rows),
        refused=sum(r["render"] == REFUSED for r in rows),
        render_failed=sum(r["render"] == RENDER_FAILED for r in rows),
        seconds_per_second=total_time / total_audio if total_audio else float("nan"),
        worst_seconds_per_second=max((_per_second(r) for r in rows), default=0.0),
    )


def _per_second(row: dict) -> float:
    """Seconds of analysis per second of audio of a scene's row (0 for one not rendered)."""
    return row["seconds"] / row["duration"] if row["duration"] else 0.0


def format_random(result: dict) -> str:
    """The table of :func:`run_random` (Markdown)."""
    lines = [
        f"random scenes (seed {result['seed']}), rendered by the engine and analysed with the "
        f"defaults; audible: own energy over its window >= {AUDIBLE_TMR_DB:g} dB of the "
        f"ringing's and peak within {AUDIBLE_RANGE_DB:g} dB of the recording's",
        "| # | scene | impacts (audible) | ticks | false | impossible | audible missed | "
        "audio (s) | analysis s per s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for i, r in enumerate(result["rows"], 1):
        note = f" (error: {r['error']})" if r["error"] else ""
        if r["render"] != SCORED:
            note = f" ({r['error']})"
        lines.append(
            f"| {i} | {r['scene']}{note} | {r['impacts']} ({r['audible']}) | {r['ticks']} | "
            f"{r['false_ticks']} | {r['impossible']} | {r['missed']} | {r['duration']:.1f} | "
            f"{_per_second(r):.3f} |"
        )
    lines.append(
        f"total: {result['impacts']} impacts ({result['audible']} audible), "
        f"{result['false_ticks']} false ticks, {result['impossible']} impossible values, "
        f"{result['missed']} audible impacts missed, "
        f"{result['seconds_per_second']:.3f} s of analysis per s of audio "
        f"(worst scene {result['worst_seconds_per_second']:.3f}); "
        f"{result['refused']} scenes refused by the engine, "
        f"{result['render_failed']} renders failed"
    )
    return "\n".join(lines)
