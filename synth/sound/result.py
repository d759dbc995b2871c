"""What a render returns: :class:`Render` (the audio, the impacts, the level) and its
:class:`RenderInfo` (the options used and what the engine did and left out)."""

from __future__ import annotations

import dataclasses
import types
from dataclasses import dataclass, field

import numpy as np

from synth.physics.bounces import BounceSequence
from synth.sound.options import RenderOptions

#: The options a render reports in :attr:`Render.settings` (``max_duration`` and
#: ``pulse_points`` set the work, not the sound's description); the bounce series' rules
#: only for a drop (a path does not use them).
_SETTINGS_OPTIONS = (
    "samplerate", "normalize", "peak_db", "loudness_lufs", "floor_db", "max_frequency",
    "preroll", "fade", "max_tail",
)  # fmt: skip
_BOUNCE_OPTIONS = ("bounce_floor_db", "max_impacts")


@dataclass(frozen=True)
class PathInfo:
    """How the path of a ball released with a horizontal velocity rolled and ended
    (:mod:`synth.physics.path`): why (``path_end``, :attr:`synth.physics.path.BallPath.end`),
    when (s from release) and where (m from the plate's corner) it ended; the speed at the
    rolling's start (m/s), its start (s from release, None: it did not roll), duration (s)
    and flights (the ball off the surface); the plate model of the path's contacts
    ("impedance"); the modes times samples of the rolling's drive (None: it did not roll)."""

    path_end: str
    path_end_time: float
    path_end_point: tuple[float, float]
    rolling_speed: float
    rolling_start: float | None
    rolling_seconds: float
    rolling_flights: int
    contact_plate: str
    rolling_mode_samples: int | None = None

    def settings(self) -> dict:
        out = dataclasses.asdict(self)
        out["path_end_point"] = list(self.path_end_point)
        if self.rolling_mode_samples is None:
            del out["rolling_mode_samples"]
        return out


@dataclass(frozen=True)
class RenderInfo:
    """The options a render used and what it did (SI units: Hz, m from the plate's corner, s
    from the release). ``left_at_end``: the bound of what rings on after the end, relative to
    ``reference_amplitude`` (the loudest tick's peak bound, Pa or m/s^2, that ``floor_db`` is
    relative to). The wall times ``*_seconds`` are not functions of the inputs;
    ``contact_seconds`` and ``transform_seconds`` take no part in equality."""

    options: RenderOptions
    listener: str
    listener_position: tuple[float, ...]
    delay: float
    audio_start: float
    n_impacts: int
    stop_reason: str
    n_modes: int
    n_modes_rendered: int
    mode_samples: int
    n_modes_overdamped: int
    tail_cut: bool
    left_at_end: float
    bank_seconds: float
    reference_amplitude: float
    path: PathInfo | None = None
    contact_seconds: float = field(default=0.0, compare=False)
    transform_seconds: float = field(default=0.0, compare=False)

    def settings(self) -> dict:
        """The flat dict of :attr:`Render.settings` (what ``synth render --report``
        writes)."""
        names = _SETTINGS_OPTIONS + (_BOUNCE_OPTIONS if self.path is None else ())
        out = {name: getattr(self.options, name) for name in names}
        for f in dataclasses.fields(self):
            if f.name not in ("options", "path"):
                out[f.name] = getattr(self, f.name)
        out["listener_position"] = list(self.listener_position)
        if self.path is not None:
            out.update(self.path.settings())
        return out


@dataclass(frozen=True, eq=False)
class Render:
    """A rendered scene: ``audio`` (float32, frames) at ``samplerate`` (Hz), the physical
    signal (``units`` "Pa" or "m/s^2") times ``gain``; the ``impacts`` rendered
    (``Impact.time`` s from the release; their ticks in the audio are :attr:`onsets`); and
    ``info``, the options used and what the engine did and left out."""

    audio: np.ndarray = field(repr=False)
    samplerate: int
    impacts: BounceSequence
    units: str
    gain: float
    info: RenderInfo = field(repr=False)

    @property
    def settings(self) -> types.MappingProxyType:
        """:attr:`info` as a read-only flat mapping (its options and figures by name, a
        path's too)."""
        return types.MappingProxyType(self.info.settings())

    @property
    def duration(self) -> float:
        """Length of the audio, s."""
        return self.audio.shape[0] / self.samplerate

    @property
    def audio_start(self) -> float:
        """Time of the first sample, s from the release of the ball."""
        return self.info.audio_start

    @property
    def onsets(self) -> np.ndarray:
        """Onset of each impact's tick in the audio, s from the first sample (the sound's
        travel time ``info.delay`` included)."""
        times = np.array([imp.time for imp in self.impacts])
        return times + self.info.delay - self.info.audio_start
