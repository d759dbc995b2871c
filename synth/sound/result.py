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
    (:mod:`synth.physics.path`, :mod:`synth.sound.path_render`).

    Attributes
    ----------
    path_end : str
        Why the path ended (:attr:`synth.physics.path.BallPath.end`).
    path_end_time : float
        When, s from release.
    path_end_point : tuple of 2 floats
        Where, m from the plate's corner.
    rolling_speed : float
        Speed at the rolling's start, m/s.
    rolling_start : float or None
        When the rolling started, s from release (None: it did not roll).
    rolling_seconds : float
        How long it rolled, s.
    rolling_flights : int
        Flights (the ball off the surface) during the rolling.
    contact_plate : str
        The plate model of the path's contacts ("impedance").
    rolling_mode_samples : int or None
        Modes times samples of the rolling's drive (None: it did not roll).
    """

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
    """The options a render used and what it did.

    Attributes
    ----------
    options : RenderOptions
        The options, checked, with ``max_frequency`` the highest frequency rendered, Hz.
    listener : str
        "microphone" or "accelerometer".
    listener_position : tuple of floats
        Its position, m (x, y on the plate; z above it for a microphone).
    delay : float
        The sound's travel time from the plate's nearest point to the listener, s (0 for
        an accelerometer).
    audio_start : float
        Time of the first sample, s from the release of the ball.
    n_impacts : int
        Impacts rendered.
    stop_reason : str
        Why the bounce series ended (:attr:`synth.physics.bounces.BounceSequence.stop_reason`).
    n_modes : int
        Modes rendered (ringing, below ``max_frequency`` and the Nyquist frequency).
    n_modes_rendered : int
        Modes heard in at least one impact's ringing (the others stay below the floor).
    mode_samples : int
        Modes times samples the modal bank computed (its work).
    n_modes_overdamped : int
        Modes left out as overdamped (they do not ring).
    tail_cut : bool
        Whether ``max_tail`` cut a tail still above the floor.
    left_at_end : float
        Bound of what rings on after the end, relative to the reference amplitude
        (dimensionless).
    bank_seconds : float
        Wall time of the modal bank, s (the one figure that is not a function of the
        inputs).
    reference_amplitude : float
        The bound on the loudest tick's peak (Pa or m/s^2) that ``floor_db`` is relative to.
    path : PathInfo or None
        A path's rolling and end (a scene with ``drop.velocity``), else None.
    contact_seconds : float
        Wall time of the drop's contacts (its bounce series), s; 0 for a path. Like
        ``bank_seconds`` not a function of the inputs; neither takes part in equality.
    transform_seconds : float
        Wall time of the pulses' transforms (the modes' excitation by every impact), s.
    """

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
    """A rendered scene.

    Attributes
    ----------
    audio : ndarray, float32, (frames,)
        The signal, scaled by ``gain`` from its physical units.
    samplerate : int
        Hz.
    impacts : BounceSequence
        The impacts rendered; ``Impact.time`` is s from the release of the ball, as
        everywhere (their ticks' places in the audio are :attr:`onsets`).
    units : str
        Physical units of ``audio / gain``: "Pa" or "m/s^2".
    gain : float
        ``audio = physical signal * gain``.
    info : RenderInfo
        The options used, and what the engine did and left out.
    """

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
        """Onset of each impact's tick in the audio, s from the first sample: the
        impact's time plus the sound's travel time ``info.delay`` (0 for an
        accelerometer) less :attr:`audio_start`."""
        times = np.array([imp.time for imp in self.impacts])
        return times + self.info.delay - self.info.audio_start
