"""The analysis on scenes beyond the presets: random valid scenes (materials from the table,
ball radius, plate size, thickness, boundary and loss factor, impact point near the middle or
near an edge, microphone above or off the plate or an accelerometer, 44.1 / 48 / 96 kHz, drop
heights), rendered by the engine and analysed. On every scene each reported tick must be one of
the rendered impacts and every impact that clearly stands out in the audio must be found, and
no tick whose restitution spans two consecutive impacts may be flagged as spanning a missed
bounce (docs/analysis.md, "What a ball cannot do").

The scenes take the default contact's surfaces but see the plate as its impedance
(:data:`CONTACT`): the analysis rests on a ball that loses energy at every impact, which the
modal plate the default model picks near edges and on small plates does not keep (its ringing,
carried from bounce to bounce, can throw the ball back faster than it came, or take it up).

Truth: ``Render.onsets`` (the first touch of each impact, in the audio) and each impact's
contact time. A tick is the sound of one contact: its onset lies from the first touch (less
:data:`EARLY`) to the end of the contact plus :data:`LATE` and the travel time of the sound
from the impact point, where the plate moves most, beyond the first arrival that
``Render.onsets`` counts (:func:`spread`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import pytest

from synth.analysis import AnalysisError, analyze
from synth.analysis.report import MISSED_BOUNCE
from synth.constants import SOUND_SPEED
from synth.physics import materials
from synth.physics.materials import LossFactor
from synth.physics.scene import Accelerometer, Ball, Contact, Microphone, Plate, Scene
from synth.sound.render import nearest_distance, render

BALLS = ("steel", "glass", "aluminium", "brass", "porcelain", "polycarbonate", "abs", "oak")
PLATES = ("aluminium", "steel", "glass", "brass", "copper", "acrylic", "mdf-12", "plywood", "oak")
RATES = (44100, 48000, 96000)
BOUNDARIES = ("free", "simply-supported", "clamped")
#: Most plate modes under the Nyquist frequency (their asymptotic count, below): keeps every
#: render a few seconds on a cold cache; the scenes above it are drawn again.
MAX_MODES = 100
#: A tick may start this much before the first touch, s: its onset is the level crossing of
#: the whitened burst, interpolated between samples, and a filter's pre-ringing (docs/analysis.md,
#: step 4) may take it up to about four sample periods early at 44.1 kHz.
EARLY = 0.0001
#: ... and this much after the end of the contact, s: weak ticks (``strength`` of a few dB)
#: start late where what the whitening leaves of the earlier ringing hides the start of their
#: burst (docs/analysis.md, Method); the last flights are still milliseconds long, so no
#: other impact lies within this.
LATE = 0.00025
#: An impact clearly stands out when the peak of the audio over its contact (at least 1 ms from
#: the first touch) is this far over the peak of the 3 ms before it, dB.
STANDS_OUT_DB = 6.0
BEFORE = 0.003
#: Scenes drawn (seeds 0 to 29): about 75 s of work on a cold cache. Seeds up to 49 pass too
#: (``python tests/test_recordings_scenes.py 0 50``).
SCENES = 30
#: The analysis' measurement window, s: a burst in the recording's last window that continues
#: a shrinking series cannot be told from a tick cut short by the end (docs/analysis.md, "What
#: a ball cannot do"); a render stopped at ``max_duration`` fades out there while the plate
#: rings, so reported ticks in it are not checked.
END_WINDOW = 0.02
#: The scenes' contact: the default model's surfaces, the plate as its impedance (a ball that
#: loses energy at every impact, the analysis' premise; see the module's docstring).
CONTACT = Contact(plate="impedance")


def mode_count(plate: Plate, f_max: float) -> float:
    """Asymptotic number of a plate's bending modes under ``f_max`` Hz (Weyl's law for the
    biharmonic operator): ``N = S f sqrt(12 rho (1 - nu^2) / E) / (2 h)``."""
    m = plate.material
    return (
        plate.length
        * plate.width
        * f_max
        * math.sqrt(12.0 * m.density * (1.0 - m.poisson**2) / m.young)
        / (2.0 * plate.thickness)
    )


def _impact_point(rng: np.random.Generator, a: float, b: float) -> tuple[float, float]:
    """The middle 80 % of the plate, or 1 to 5 cm from one of its edges (40 %)."""
    if rng.random() >= 0.4:
        return (float(rng.uniform(0.1, 0.9) * a), float(rng.uniform(0.1, 0.9) * b))
    d = float(rng.uniform(0.01, 0.05))
    if rng.random() < 0.5:
        return (d if rng.random() < 0.5 else a - d, float(rng.uniform(d, b - d)))
    return (float(rng.uniform(d, a - d)), d if rng.random() < 0.5 else b - d)


def _listener(rng: np.random.Generator, a: float, b: float):
    """A microphone 10 to 60 cm up, anywhere over the plate or up to 20 cm off its edges
    (75 %), or an accelerometer on the plate."""
    if rng.random() < 0.75:
        return Microphone(
            (
                float(rng.uniform(-0.2, a + 0.2)),
                float(rng.uniform(-0.2, b + 0.2)),
                float(rng.uniform(0.1, 0.6)),
            )
        )
    return Accelerometer((float(rng.uniform(0.05, 0.95) * a), float(rng.uniform(0.05, 0.95) * b)))


def random_scene(rng: np.random.Generator) -> tuple[Scene, int]:
    """A random valid scene and its sample rate (Hz), with at most :data:`MAX_MODES` modes."""
    while True:
        fs = int(rng.choice(RATES))
        eta = float(10.0 ** rng.uniform(-3.7, -1.7))
        material = dataclasses.replace(
            materials.get(str(rng.choice(PLATES))), damping=LossFactor(eta)
        )
        a, b = float(rng.uniform(0.2, 0.9)), float(rng.uniform(0.2, 0.7))
        plate = Plate(material, float(rng.uniform(0.002, 0.012)), a, b, str(rng.choice(BOUNDARIES)))
        if mode_count(plate, fs / 2) > MAX_MODES:
            continue
        ball = Ball(str(rng.choice(BALLS)), float(rng.uniform(0.003, 0.015)))
        scene = Scene(
            ball,
            plate,
            drop_height=float(rng.uniform(0.02, 0.3)),
            position=_impact_point(rng, a, b),
            listener=_listener(rng, a, b),
            contact=CONTACT,
        )
        return scene, fs


def spread(scene: Scene, fs: int) -> float:
    """How much later than the first arrival (``Render.onsets``) the sound from the impact
    point may come, s. A microphone hears the nearest point of the plate first, the impact
    point ``(R - R0) / c`` later; an accelerometer feels the bending wave from the impact
    point after ``d / c_g`` at the group speed of its fastest component, at the Nyquist
    frequency: ``c_g = 2 sqrt(omega) (D / rho h)^(1/4)``."""
    x, y = scene.position
    lis = scene.listener
    if isinstance(lis, Microphone):
        r = math.dist((x, y, 0.0), lis.position)
        return (r - nearest_distance(scene.plate, lis)) / SOUND_SPEED
    p = scene.plate
    bending = p.flexural_rigidity / p.surface_density
    c_g = 2.0 * math.sqrt(math.pi * fs) * bending**0.25
    return math.dist((x, y), lis.position) / c_g


@dataclass(frozen=True)
class Truth:
    """A render's impacts in its audio: first touches and contact ends (s), and whether
    each clearly stands out (:data:`STANDS_OUT_DB`)."""

    starts: np.ndarray
    ends: np.ndarray
    audible: np.ndarray


def truth(scene: Scene, rendered) -> Truth:
    fs = rendered.samplerate
    x = np.abs(rendered.audio.astype(float))
    starts = rendered.onsets
    ends = starts + np.array([imp.result.contact_time for imp in rendered.impacts])
    ends = ends + spread(scene, fs)
    audible = []
    for s, e in zip(starts, ends):
        k = int(math.ceil(s * fs))
        span = x[k : int(math.ceil(max(e, s + 0.001) * fs)) + 1]
        before = x[max(0, k - int(round(BEFORE * fs))) : k]
        level = span.max() if span.size else 0.0
        audible.append(
            level > 10.0 ** (STANDS_OUT_DB / 20.0) * (before.max() if before.size else 0.0)
        )
    return Truth(starts, ends, np.array(audible, bool))


def matches(times: np.ndarray, t: Truth) -> list[int | None]:
    """For each tick time, the impact whose contact it falls in (with the margins), or None."""
    out = []
    for time in times:
        hit = np.flatnonzero((time >= t.starts - EARLY) & (time <= t.ends + LATE))
        out.append(int(hit[0]) if hit.size else None)
    return out


def render_scene(seed: int):
    scene, fs = random_scene(np.random.default_rng(seed))
    return scene, render(scene, samplerate=fs, max_duration=1.0, max_tail=0.3)


def check_scene(seed: int) -> list[str]:
    """What is wrong with the analysis of the random scene ``seed``: false, doubled and
    missed ticks (empty when right)."""
    scene, rendered = render_scene(seed)
    t = truth(scene, rendered)
    try:
        an = analyze(rendered.audio, rendered.samplerate)
        times = np.array([tk.time for tk in an.ticks])
    except AnalysisError as exc:
        return [f"seed {seed}: {exc}"]
    hit = matches(times, t)
    end = rendered.duration - END_WINDOW
    problems = [
        f"seed {seed}: false tick at {times[i]:.5f} s"
        for i, h in enumerate(hit)
        if h is None and times[i] < end
    ]
    found = [h for h in hit if h is not None]
    problems += [
        f"seed {seed}: impact {h + 1} found twice" for h in set(found) if found.count(h) > 1
    ]
    problems += [
        f"seed {seed}: missed impact {i + 1} at {t.starts[i]:.5f} s"
        for i in np.flatnonzero(t.audible)
        if i not in found
    ]
    problems += [
        f"seed {seed}: tick {k + 1} flagged {MISSED_BOUNCE} over consecutive impacts"
        for k in false_missed_bounces(an.ticks, hit)
    ]
    return problems


def false_missed_bounces(ticks, hit: list[int | None]) -> list[int]:
    """Ticks flagged as spanning a missed bounce whose restitution spans none: the tick and
    the two before it are consecutive rendered impacts (``hit``: each tick's impact, or
    None)."""
    return [
        k
        for k, tk in enumerate(ticks)
        if MISSED_BOUNCE in tk.flags
        and k >= 2
        and None not in hit[k - 2 : k + 1]
        and hit[k] - hit[k - 1] == hit[k - 1] - hit[k - 2] == 1
    ]


@pytest.mark.slow
def test_random_scenes():
    # every reported tick is a real impact, every impact that stands out is found, no
    # restitution over consecutive impacts is flagged as spanning a missed bounce
    problems = [p for seed in range(SCENES) for p in check_scene(seed)]
    assert not problems, "\n".join(problems)


if __name__ == "__main__":  # diagnostics: python tests/test_recordings_scenes.py FIRST COUNT
    import sys

    first, count = int(sys.argv[1]), int(sys.argv[2])
    for seed in range(first, first + count):
        scene, fs = random_scene(np.random.default_rng(seed))
        out = check_scene(seed)
        print(
            f"seed {seed}: {fs} Hz, {scene.ball.material.name} {scene.ball.radius * 2e3:.0f} mm "
            f"on {scene.plate.material.name} {scene.plate.thickness * 1e3:.1f} mm "
            f"{scene.plate.boundary} eta {scene.plate.material.damping.eta:.1e} at "
            f"{np.round(scene.position, 3)}, {type(scene.listener).__name__}"
        )
        for p in out:
            print("   ", p)
