"""Alter a recorded bouncing sound by the thesis' rule ``1 - e'_n = k (1 - e_n)`` (section
5.2.2), new bounce times ``T'_n = e'_n T'_(n-1)``: each tick's own sound re-laid at its new
onset (:mod:`synth.stimuli.splice`, :mod:`synth.stimuli.prediction`; docs/analysis.md,
"Altering a recording")."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from synth import checks
from synth.errors import ParameterError
from synth.stimuli.splice import SplicedChannel, TickLayout

#: Before each onset, s (at most half the shortest bounce): where the fits end and the
#: prediction starts, clear of an anti-aliasing filter's pre-echo of the attack (a few tenths
#: of a ms); where a tick's own sound starts (the onsets are known to about a sample period).
GUARD = 0.0005
LEAD = 0.0001

#: After an onset, left out of the fits (under the contact), s; at most half the bounce. The
#: analysis' default ``min_separation``, which exceeds the contact time.
EXCITATION = 0.001
#: The last FADE s of the output are faded out.
FADE = 0.005

#: Output levels.
NORMALIZE_MODES = ("none", "peak")


@dataclass(frozen=True)
class _Timing:
    """Measured bounces ``T_n`` (s) and restitutions ``e_n``, the rule's ``e'_n`` and the new
    bounces ``T'_n`` (s) up to the end of the altered series."""

    bounces: np.ndarray
    restitution: np.ndarray
    new_restitution: np.ndarray
    new_bounces: np.ndarray

    @classmethod
    def of(cls, t, k: float, min_bounce: float) -> _Timing:
        """The timing of onsets ``t`` (s) altered by ``k``, ending before a bounce shorter
        than ``min_bounce`` (s)."""
        T = np.diff(t)
        e = T[1:] / T[:-1]
        e_new = 1.0 - k * (1.0 - e)
        T_new = [T[0]]
        for en in e_new:
            tn = en * T_new[-1]
            if not tn >= min_bounce * (1.0 - 1e-9):  # to rounding: k = 1 keeps every tick
                break
            T_new.append(tn)
        return cls(T, e, e_new, np.array(T_new))

    def too_short(self, k: float, min_bounce: float) -> ParameterError:
        """The error of an alteration that leaves fewer than 3 ticks, with the largest ``k``."""
        e, e_new, T, T_new = self.restitution, self.new_restitution, self.bounces, self.new_bounces
        if e_new[0] <= 0.0:  # no rebound at all (a bounce time would be meaningless)
            why = "<= 0: the ball would not rebound"
        else:
            why = f"a bounce of {T_new[0] * e_new[0] * 1e3:.3g} ms against min_bounce = "
            why += f"{min_bounce * 1e3:.3g} ms"
        return ParameterError(
            f"restitution_scale={k!r} ends the series after 2 ticks (e' = 1 - k (1 - e) = "
            f"{e_new[0]:.3g} at the second impact, {why}): no altered bounce is left; "
            f"k must be < {(1.0 - min_bounce / T[0]) / (1.0 - e[0]):.4g} here"
        )


def _check_one_series(t: np.ndarray) -> None:
    """Refuse onsets that are not one bounce series: ``e_n >= 1`` is a missed tick or a new
    drop, which the rule would turn the wrong way (``k > 1`` raises an ``e_n > 1``)."""
    T = np.diff(t)
    grown = np.nonzero(T[1:] >= T[:-1])[0]
    if grown.size:
        n = int(grown[0])
        raise ParameterError(
            f"onsets are not one bounce series: the bounce before tick {n + 3} "
            f"({T[n + 1] * 1e3:.4g} ms) is not shorter than the one before it "
            f"({T[n] * 1e3:.4g} ms), e = {T[n + 1] / T[n]:.3g} >= 1, which no ball does (a "
            f"tick missed in between, or a new drop); pass the onsets of one series, every "
            f"tick found (synth.analyze reports each series and flags such ticks)"
        )


@dataclass(frozen=True)
class AlterOptions:
    """How :func:`alter_restitution` re-lays the ticks and sets the output's level; checked when
    made. ``scale_amplitude``: scale each tick's own sound by its new impact speed over its old
    one; ``min_bounce`` (s, at least 2 sample periods; default the recording's shortest
    bounce): the series ends before a shorter bounce; ``normalize``: "none" (the recording's
    units and level) or "peak" (the largest sample at ``peak_db`` dBFS, <= 0); ``seed`` (>= 0)
    of the synthesised background noise, so the output is reproducible."""

    scale_amplitude: bool = True
    min_bounce: float | None = None
    normalize: str = "none"
    peak_db: float = -1.0
    seed: int = 0

    def __post_init__(self):
        if self.min_bounce is not None:
            checks.positive("min_bounce", self.min_bounce, "s")
        checks.choice("normalize", self.normalize, NORMALIZE_MODES)
        if checks.real("peak_db", self.peak_db, "dBFS") > 0.0:
            raise ParameterError(f"peak_db={self.peak_db!r} must be <= 0 (dBFS)")
        if not isinstance(self.scale_amplitude, (bool, np.bool_)):
            raise ParameterError(f"scale_amplitude={self.scale_amplitude!r} must be True or False")
        checks.integer_at_least("seed", self.seed, 0)


@dataclass(frozen=True)
class Alteration:
    """:func:`alter_restitution`'s ``audio`` (float64, the recording's channels and units unless
    ``normalize="peak"``); ``onsets`` (s) of the ``M`` ticks kept; the ``N - 2`` measured
    ``restitution`` of ``N`` onsets and the ``M - 2`` ``new_restitution``."""

    audio: np.ndarray
    onsets: np.ndarray
    restitution: np.ndarray
    new_restitution: np.ndarray


def alter_restitution(
    audio,
    samplerate,
    restitution_scale,
    *,
    onsets=None,
    gravity=9.81,
    channel=None,
    options: AlterOptions | None = None,
    **overrides,
) -> Alteration:
    """Change the restitution of a recorded bouncing sound by ``1 - e' = k (1 - e)``.

    ``audio`` (frames,) or (frames, channels), any units (kept), at ``samplerate`` Hz;
    ``restitution_scale`` ``k >= 0``; ``onsets`` (s): at least 3 ticks of one bounce series,
    at least 2 samples apart (default: detected by :func:`synth.analysis.analyze` with
    ``gravity``, m/s^2, on ``channel``, None: the mean; every channel is altered);
    ``options`` (:class:`AlterOptions`) and ``overrides`` of its fields by name. Raises
    ``ParameterError`` for bad input, onsets that are not one series or fewer than 3 ticks left."""
    from synth.analysis.settings import audio_array

    o = dataclasses.replace(options or AlterOptions(), **overrides)
    X = audio_array(audio)
    fs = checks.positive("samplerate", samplerate, "Hz")
    k = checks.nonnegative("restitution_scale", restitution_scale, "dimensionless")
    t = _checked_onsets(X, fs, onsets, gravity, channel)
    # the recording's shortest bounce by default (at least 2 sample periods, as the onsets)
    min_b = float(np.min(np.diff(t)) if o.min_bounce is None else o.min_bounce)
    if min_b < 2.0 / fs:
        raise ParameterError(
            f"min_bounce={o.min_bounce!r} must be at least 2 sample periods "
            f"({2.0 / fs:.4g} s at {fs:g} Hz)"
        )
    timing = _Timing.of(t, k, min_b)
    T, T_new = timing.bounces, timing.new_bounces
    M = T_new.size + 1
    if M < 3:
        raise timing.too_short(k, min_b)
    t_new = np.r_[t[0], t[1] + np.r_[0.0, np.cumsum(T_new[1:])]]  # t'_1 = t_1 exactly
    gain = np.ones(M)
    if o.scale_amplitude:
        gain[1:] = T_new / T[: M - 1]  # v'_n / v_n, for the tick after each bounce
    layout = _layout(fs, t, t_new, T, gain, min_b)
    parts = [
        SplicedChannel(X[:, ch], fs, layout, np.random.default_rng([int(o.seed), ch]))
        for ch in range(X.shape[1])
    ]
    Y = _joined(parts, X, fs)
    if o.normalize == "peak":
        peak = float(np.max(np.abs(Y)))
        if peak > 0.0:
            Y = (Y / peak) * 10.0 ** (o.peak_db / 20.0)
    T_kept = np.diff(t_new)
    return Alteration(
        Y[:, 0] if np.ndim(audio) == 1 else Y, t_new, timing.restitution, T_kept[1:] / T_kept[:-1]
    )


def _checked_onsets(x, fs, onsets, gravity, channel):
    """The tick onsets, s (given, or :func:`synth.analysis.analyze`'s), one series in the audio."""
    if onsets is None:
        from synth.analysis import analyze

        onsets = [t.time for t in analyze(x, fs, gravity=gravity, channel=channel).ticks]
    t, frames = np.asarray(onsets, dtype=float), x.shape[0]
    if t.ndim != 1 or t.size < 3 or not np.all(np.isfinite(t)):
        raise ParameterError(f"onsets must be at least 3 finite times (s), got shape {t.shape}")
    if np.any(np.diff(t) < 2.0 / fs) or t[0] < 0.0 or t[-1] * fs >= frames:
        raise ParameterError(
            f"onsets must increase by at least 2 sample periods ({2e3 / fs:.4g} ms) and lie "
            f"inside the audio (0 to {frames / fs:.6g} s)"
        )
    _check_one_series(t)
    return t


def _layout(fs, t, t_new, T, gain, min_b) -> TickLayout:
    """The ticks at ``t`` laid at ``t_new`` (s) with ``gain``; ``T``: the recorded bounces,
    ``min_b``: the shortest new one, s."""
    M = gain.size
    guard = min(GUARD, 0.5 * min_b, 0.5 * float(np.min(T)))
    lead = min(LEAD, guard)
    cut = np.maximum(np.round((t - guard) * fs).astype(int), 0)
    join_new = np.maximum(np.round((t_new - lead) * fs).astype(int), 0)
    return TickLayout(
        cut=cut,
        join=np.maximum(np.round((t - lead) * fs).astype(int), 0),
        join_new=join_new,
        gain=gain,
        speed=np.r_[1.0, T[: M - 1] / T[0]],  # v_j / v_1, for the template of a tail
        excluded=_under_contacts(cut, t * fs, fs),
        excluded_new=_under_contacts(join_new, t_new * fs, fs),
        lead=lead,
    )


def _under_contacts(start, onsets, fs) -> list[tuple[int, int]]:
    """``(start, onset + EXCITATION)`` of each contact, samples, at most half the bounce."""
    reach = np.minimum(EXCITATION * fs, 0.5 * np.r_[np.diff(onsets), np.inf])
    return [(int(c), int(math.ceil(o + r))) for c, o, r in zip(start, onsets, reach)]


def _joined(parts, X, fs):
    """The spliced channels, ending together, faded out over FADE s (``X`` copied for
    ``k = 1``)."""
    if all(part.unchanged for part in parts):
        return X.copy()
    n_out = max(part.end for part in parts)  # the channels end together
    Y = np.stack([part.finish(n_out) for part in parts], axis=1)
    nf = min(Y.shape[0], max(1, int(round(FADE * fs))))
    Y[-nf:] *= 0.5 * (1.0 + np.cos(np.pi * np.arange(1, nf + 1) / nf))[:, None]
    return Y
