"""Regenerate tests/data/sdt/: bouncing sounds made by another engine, the Sound Design Toolkit
(SDT, https://github.com/SkAT-VG/SDT, through its Python bindings ``pysdt``: ``pip install
pysdt``), degraded as recordings are, with their truth.

SDT's bouncing model (Rocchesso and Fontana, eds., *The Sounding Object*, 2003, ch. 8; the
``bouncing~`` and ``impact~`` objects): a ``Bouncing`` control gives the impact velocities of
a ball with a fixed restitution (each flight ``e`` times the one before, each impact speed
``e`` times the one before); each strikes an inertial hammer against a modal resonator through
the Hunt-Crossley contact force ``F = k x^a + lambda x^a v`` (Avanzini and Rocchesso 2001,
"Modeling collision sounds: non-linear contact force", DAFx). The recording is the resonator's
velocity at a pickup away from the contact. The contact is stiff (``k = 1e10``, resonator
weight 0.001): the contacts last a few samples, as a hard ball's on a plate. Truth: the sample
of each strike (the contact starts there: SDT sets the hammer's velocity at the contact
point), the last sample of each strike's first contact (its force last non-zero) and the
restitution.

Each file is written with its truth in ``NAME.json`` (tick times in s, restitution, the
degradation). Degradations: white noise at -30 or -40 dB of the clean signal's peak; a room
(the direct sound plus exponentially decaying white noise, RT60 0.3 to 0.6 s, whose energy is a
given fraction of the direct sound's); lossy OGG/Vorbis encoding. Run from the repository:
``python tests/data/make_sdt_recordings.py``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import soundfile

OUT = Path(__file__).with_name("sdt")
FS = 44100
DURATION = 1.6


@dataclass(frozen=True)
class Recording:
    """One file: the SDT scene (restitution, drop height m, hammer mass kg, resonator modes:
    frequencies Hz, decay times s, pickup gains; the contact's stiffness, N/m^1.5, and SDT's
    modal weight of the resonator) and its degradation."""

    name: str
    restitution: float
    height: float
    mass: float
    freqs: tuple[float, ...]
    decays: tuple[float, ...]
    gains: tuple[float, ...]
    stiffness: float = 1e10
    weight: float = 0.001
    noise_db: float | None = None
    rt60: float | None = None
    reverb_db: float = 0.0
    encoding: str = "FLAC"
    seed: int = 0


RECORDINGS = (
    Recording(
        "wood-noise40",
        0.7,
        0.15,
        0.01,
        (310.0, 742.0, 1385.0, 2210.0, 3190.0, 4630.0),
        (0.06, 0.04, 0.03, 0.02, 0.015, 0.01),
        (1.0, -0.7, 0.5, 0.6, -0.4, 0.3),
        noise_db=-40.0,
    ),
    Recording(
        "metal-noise30",
        0.8,
        0.2,
        0.02,
        (523.0, 1287.0, 2990.0, 4110.0, 6110.0),
        (0.4, 0.3, 0.2, 0.12, 0.08),
        (1.0, 0.6, -0.4, 0.5, 0.25),
        noise_db=-30.0,
        seed=1,
    ),
    Recording(
        "glass-room",
        0.75,
        0.2,
        0.005,
        (880.0, 2140.0, 3950.0, 6300.0, 9050.0),
        (0.25, 0.15, 0.1, 0.06, 0.04),
        (1.0, -0.8, 0.6, 0.4, 0.3),
        noise_db=-40.0,
        rt60=0.4,
        reverb_db=-6.0,
        seed=2,
    ),
    Recording(
        "wood-room-ogg",
        0.65,
        0.25,
        0.01,
        (250.0, 610.0, 1180.0, 1930.0, 2870.0, 3990.0),
        (0.05, 0.04, 0.025, 0.02, 0.012, 0.008),
        (1.0, 0.8, -0.6, 0.5, 0.4, -0.3),
        noise_db=-40.0,
        rt60=0.6,
        reverb_db=-3.0,
        encoding="OGG",
        seed=3,
    ),
)


def sdt_bouncing(rec: Recording) -> tuple[np.ndarray, list[int], list[int]]:
    """SDT's bouncing ball on a modal resonator: the pickup's velocity, the strike samples
    and the last sample of each strike's first contact (its force last non-zero)."""
    import pysdt

    pysdt.common.set_samplerate(FS)
    hammer = pysdt.resonators.Resonator(1, 1)
    hammer.set_frequency(0, 0.0)
    hammer.set_decay(0, 0.0)
    hammer.set_weight(0, 1.0 / rec.mass)
    hammer.set_gain(0, 0, 1.0)
    hammer.active_modes = 1
    hammer.fragment_size = 1
    hammer.update()
    res = pysdt.resonators.Resonator(len(rec.freqs), 2)
    for i, (f, tau, g) in enumerate(zip(rec.freqs, rec.decays, rec.gains)):
        res.set_frequency(i, f)
        res.set_decay(i, tau)
        res.set_weight(i, rec.weight)
        res.set_gain(0, i, 1.0)  # the contact point
        res.set_gain(1, i, g)  # the pickup
    res.active_modes = len(rec.freqs)
    res.fragment_size = 1
    res.update()
    impact = pysdt.interactors.Impact()
    impact.stiffness = rec.stiffness
    impact.dissipation = 0.5
    impact.shape = 1.5
    impact.first_resonator = hammer
    impact.second_resonator = res
    impact.first_point = 0
    impact.second_point = 0
    ball = pysdt.control.Bouncing()
    ball.restitution = rec.restitution
    ball.height = rec.height
    ball.irregularity = 0.0
    ball.reset()
    n = int(DURATION * FS)
    out = np.zeros(n)
    strikes, ends = [], []
    touching = False
    for k in range(n):
        v = ball.dsp()
        if v > 0.0:
            strikes.append(k)
            ends.append(k)
            touching = True
        impact.dsp(0.0, -v if v > 0.0 else 0.0, 0.0, 0.0, 0.0, 0.0)
        if touching and impact.compute_force() != 0.0:
            ends[-1] = k
        elif touching and k > strikes[-1]:
            touching = False  # the first contact of the strike is over
        out[k] = res.get_velocity(1)
    return out, strikes, ends


def room(x: np.ndarray, rt60: float, level_db: float, rng: np.random.Generator) -> np.ndarray:
    """``x`` in a synthetic room: the direct sound plus exponentially decaying white noise
    (amplitude falling 60 dB in ``rt60`` s) carrying ``level_db`` of the direct sound's
    energy."""
    t = np.arange(int(1.5 * rt60 * FS)) / FS
    tail = rng.standard_normal(t.size) * np.exp(-3.0 * math.log(10.0) * t / rt60)
    tail *= math.sqrt(10.0 ** (level_db / 10.0) / np.sum(tail**2))
    tail[0] += 1.0
    return np.convolve(x, tail)[: x.size]


def degraded(rec: Recording) -> tuple[np.ndarray, list[int], list[int]]:
    x, strikes, ends = sdt_bouncing(rec)
    rng = np.random.default_rng(rec.seed)
    x = x / np.abs(x).max()
    if rec.rt60 is not None:
        x = room(x, rec.rt60, rec.reverb_db, rng)
    if rec.noise_db is not None:
        x = x + 10.0 ** (rec.noise_db / 20.0) * rng.standard_normal(x.size)
    return 0.5 * x / np.abs(x).max(), strikes, ends


def main() -> None:
    OUT.mkdir(exist_ok=True)
    for rec in RECORDINGS:
        x, strikes, ends = degraded(rec)
        ext = {"FLAC": "flac", "OGG": "ogg"}[rec.encoding]
        path = OUT / f"{rec.name}.{ext}"
        subtype = "PCM_16" if rec.encoding == "FLAC" else "VORBIS"
        tmp = path.with_name(f".{path.name}.tmp")
        soundfile.write(tmp, x, FS, format=rec.encoding, subtype=subtype)
        tmp.replace(path)
        truth = {
            "file": path.name,
            "samplerate": FS,
            "engine": "Sound Design Toolkit (pysdt): control.Bouncing, interactors.Impact",
            "restitution": rec.restitution,
            "ticks": [k / FS for k in strikes],
            "contact_ends": [k / FS for k in ends],
            "noise_db": rec.noise_db,
            "rt60": rec.rt60,
            "reverb_db": rec.reverb_db if rec.rt60 is not None else None,
            "encoding": rec.encoding,
        }
        tmp = OUT / f".{rec.name}.json.tmp"
        tmp.write_text(json.dumps(truth, indent=1) + "\n")
        tmp.replace(OUT / f"{rec.name}.json")
        print(path, path.stat().st_size, "bytes,", len(strikes), "strikes")


if __name__ == "__main__":
    main()
