"""Render a scene: bounces -> plate modes -> exact modal synthesis -> level.

``render(scene, samplerate=48000)`` returns a :class:`Render` with the audio
(float32), the impacts (times from release) with their onsets in the audio, and the
settings used. Its signal is what the scene's listener picks up: plate acceleration
(m/s^2) for an :class:`~synth.physics.scene.Accelerometer`, sound pressure (Pa) for a
:class:`~synth.physics.scene.Microphone` above the baffled plate, scaled by the level
stage (``normalize``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from synth import checks, cost
from synth.constants import AIR_DENSITY, SOUND_SPEED
from synth.errors import ParameterError, SynthError
from synth.io import cache as disk_cache
from synth.physics.bounces import (
    DEFAULT_FLOOR_DB,
    DEFAULT_MAX_IMPACTS,
    BounceSequence,
    simulate_scene,
)
from synth.physics.scene import Accelerometer, Microphone, Scene
from synth.sound import modes as plate_modes
from synth.sound.modal_bank import PULSE_POINTS, synthesize

NORMALIZE = ("peak", "loudness", "physical", "none")


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
    settings : dict
        The render settings used, and what the engine left out.
    """

    audio: np.ndarray = field(repr=False)
    samplerate: int
    impacts: BounceSequence
    units: str
    gain: float
    settings: dict = field(repr=False)

    @property
    def duration(self) -> float:
        """Length of the audio, s."""
        return self.audio.shape[0] / self.samplerate

    @property
    def audio_start(self) -> float:
        """Time of the first sample, s from the release of the ball."""
        return self.settings["audio_start"]

    @property
    def onsets(self) -> np.ndarray:
        """Onset of each impact's tick in the audio, s from the first sample: the
        impact's time plus the sound's travel time ``settings["delay"]`` (0 for an
        accelerometer) less :attr:`audio_start`."""
        times = np.array([imp.time for imp in self.impacts])
        return times + self.settings["delay"] - self.settings["audio_start"]


#: Range of the sample rate, Hz.
MIN_SAMPLERATE, MAX_SAMPLERATE = 8000, 384000


def _samplerate(value) -> int:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, np.integer))
        or not MIN_SAMPLERATE <= value <= MAX_SAMPLERATE
    ):
        raise ParameterError(
            f"samplerate={value!r} must be an integer number of Hz in "
            f"[{MIN_SAMPLERATE}, {MAX_SAMPLERATE}]"
        )
    return int(value)


def _microphone_gains(modes, plate, microphone, poles, k_max, max_points=None):
    """Pressure per unit modal velocity (Pa s/m) of every mode at the scene's microphone,
    for the ringing ``exp(p_k t)`` that starts :func:`_delay` after each impact.

    A mode rings only after its impact, so a plate element at distance ``R`` is heard
    from ``R / c`` on: the Rayleigh integral's exact gain at the pole, ``H_k(p_k)``,
    holds only once every element has been heard, and it weights an element by
    ``exp(sigma_k (R - R0) / c)``, the mode's amplitude when that element's sound set
    out: for strongly damped modes and large plates (1 / sigma_k shorter than the
    spread of arrival times), a growth of many orders of magnitude that the early
    samples would carry. Instead each mode gets the one complex gain that makes its
    ringing ``G_k exp(p_k t)``, from the first arrival ``R0 / c`` on (``R0`` the
    distance to the nearest point of the plate), closest in the least-squares sense to
    the causal pressure: the projection of ``Int W(tau) exp(p (t - tau)) [t > tau] dtau``
    (``W`` the arrival-time density of ``phi_k / R``) on ``exp(p t)``, which is

        G_k = (rho p_k / 2 pi) Int phi_k exp(-(sigma_k + i omega_k) (R - R0) / c) / R dA
            = H_k(s'_k) p_k / s'_k,      s'_k = sigma_k + i omega_k = -conj(p_k),

    the Rayleigh gain at the mirror pole: every element weighted by ``exp(-sigma_k (R -
    R0) / c) <= 1`` (so ``|G_k|`` never exceeds the in-phase bound), and equal to
    ``H_k(p_k)`` for a lightly damped mode (``sigma_k (R - R0) / c << 1``). Cached: see
    :func:`synth.sound.radiation.plate_gains`.
    """
    from synth.sound.radiation import plate_gains

    mirror = -np.conj(poles)
    gains = functools.partial(
        plate_gains,
        modes,
        microphone.position,
        mirror,
        max_wavenumber=k_max,
        air_density=AIR_DENSITY,
        sound_speed=SOUND_SPEED,
        reference_distance=nearest_distance(plate, microphone),
    )
    if max_points is None:
        return np.asarray(gains()) * poles / mirror
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        h = gains(max_points=max_points)
    for w in caught:
        warnings.warn_explicit(
            _budget_named(w.message, max_points), w.category, w.filename, w.lineno
        )
    return np.asarray(h) * poles / mirror


def _budget_named(message, max_points):
    """A warning of the sums stopped at ``max_points`` (the render's radiation budget's
    cut, :attr:`synth.cost.RadiationWork.max_points`) reworded to name the setting the
    user can change, ``SYNTH_MAX_RADIATION_WORK``; any other warning as it is."""
    internal = f"the next rule would exceed max_points={max_points}"
    text = str(message)
    if internal not in text:
        return message
    return type(message)(
        text.replace(
            internal,
            "the next rule would exceed the radiation budget SYNTH_MAX_RADIATION_WORK (raise "
            "it for converged gains; synth info --cost prints the work)",
        )
    )


def nearest_distance(plate, microphone) -> float:
    """Distance (m) from the microphone to the nearest point of the plate."""
    x, y, z = microphone.position
    p = plate
    dx = max(0.0, -x, x - p.length)
    dy = max(0.0, -y, y - p.width)
    return math.sqrt(dx * dx + dy * dy + z * z)


@dataclass(frozen=True, eq=False)
class ListenerOutput:
    """How a listener hears the plate's modes.

    output: complex (K,), listener gain per unit modal displacement ``q_k`` at the pole
    (``phi_k(xp) p_k^2`` for acceleration, m/s^2 per m; ``G_k p_k`` for a microphone, Pa
    per m); shape: ``phi_k(xp)`` for the accelerometer's direct term inside contacts, or
    None; delay: the sound's travel time to the listener from the nearest point of the
    plate, s; units: "m/s^2" or "Pa".
    """

    output: np.ndarray
    shape: np.ndarray | None
    delay: float
    units: str


def _accelerometer_output(
    modes, plate, listener, poles, ok, sigma, omega, wd, max_points=None
) -> ListenerOutput:
    phip = modes.shapes(np.array([listener.position]))[0][ok]
    return ListenerOutput(phip * poles**2, phip, 0.0, LISTENER_UNITS[Accelerometer])


def _microphone_output(
    modes, plate, listener, poles, ok, sigma, omega, wd, max_points=None
) -> ListenerOutput:
    k_max = _max_wavenumber(plate, omega[ok])
    s = _sum_poles(sigma, omega, wd, ok)
    all_gains = _microphone_gains(modes, plate, listener, s, k_max, max_points)
    return _pressure_output(all_gains, poles, ok, plate, listener)


def _sum_poles(sigma, omega, wd, ok):
    """The poles ``s_k`` (rad/s) the radiation sums take for every mode: a mode left out
    (``ok`` False, e.g. overdamped) takes ``-omega_k``, its gain unused: its own
    ``-sigma_k`` can be of any size, and the sums' panels follow the largest ``|s|``."""
    return np.where(ok, -sigma + 1j * wd, -omega + 0j)


def _max_wavenumber(plate, omega) -> float:
    """The largest bending wavenumber (rad/m) of modes of angular frequencies ``omega``
    (rad/s; 1 for none): ``(omega^2 rho h / D)^(1/4)``."""
    if omega.size == 0:
        return 1.0
    return (float(np.max(omega)) ** 2 * plate.surface_density / plate.flexural_rigidity) ** 0.25


def _pressure_output(all_gains, poles, ok, plate, microphone) -> ListenerOutput:
    """A microphone's :class:`ListenerOutput` from the gains ``G_k`` of every mode."""
    return ListenerOutput(
        np.asarray(all_gains)[ok] * poles,
        None,
        nearest_distance(plate, microphone) / SOUND_SPEED,
        LISTENER_UNITS[Microphone],
    )


#: Each kind of listener's output gains (Accelerometer: acceleration at a point of the
#: plate; Microphone: Rayleigh radiation of the baffled plate).
LISTENER_OUTPUTS = {Accelerometer: _accelerometer_output, Microphone: _microphone_output}
#: The units each kind of listener hears in.
LISTENER_UNITS = {Accelerometer: "m/s^2", Microphone: "Pa"}


@dataclass(frozen=True, eq=False)
class ModalModel:
    """A plate's modes as one listener hears them: what :func:`render` and the live engine
    (:mod:`synth.live`) build once per plate and listener.

    Attributes
    ----------
    modes : synth.sound.modes.Modes
        The plate's modes below ``max_frequency``.
    poles : complex ndarray (K,)
        ``p_k = -sigma_k + i omega_dk``, rad/s, of the ringing modes below Nyquist.
    rendered : bool ndarray
        Which of ``modes`` the poles are (overdamped modes and modes whose damped
        frequency reaches Nyquist are left out).
    listener : ListenerOutput
        The listener's gains, direct-term shape, delay (s) and units.
    n_overdamped : int
        Modes left out as overdamped (``sigma >= omega``: they do not ring).
    samplerate : int
        Hz.
    """

    modes: object
    poles: np.ndarray
    rendered: np.ndarray
    listener: ListenerOutput
    n_overdamped: int
    samplerate: int

    @property
    def output(self) -> np.ndarray:
        return self.listener.output

    @property
    def delay(self) -> float:
        return self.listener.delay

    @property
    def units(self) -> str:
        return self.listener.units

    def excitation(self, position) -> np.ndarray:
        """``b_k = phi_k(x0) / M_k`` (1/kg) of a force at ``position`` ((x, y), m)."""
        return self.excitations(np.array([position]))[0]

    def excitations(self, points) -> np.ndarray:
        """``b_k`` (1/kg) of a force at each of ``points`` ((P, 2), m): (P, K)."""
        phi = self.modes.shapes(np.asarray(points, dtype=float))[:, self.rendered]
        return phi / np.asarray(self.modes.modal_masses, dtype=float)[self.rendered]

    def heard_by(self, listener, grid=None) -> ModalModel:
        """The same modes heard by another ``listener`` (an Accelerometer or a
        Microphone of the same plate), as :func:`modal_model` computes them. With
        ``grid`` (:func:`listener_grid` of this model) a microphone it serves (at least
        its height above the plate) takes its gains from it: the sums alone, no shape
        evaluated (see :mod:`synth.sound.radiation.fixed`); any other listener is
        computed as :func:`modal_model` does (a microphone's gains by
        :func:`synth.sound.radiation.plate_gains`, cached)."""
        modes = self.modes
        plate = modes.plate
        sigma, omega, wd = _mode_rates(modes)
        ok = self.rendered
        microphone = isinstance(listener, Microphone)
        if microphone and grid is not None and grid.serves(listener.position):
            poles = -sigma + 1j * wd
            h = grid.gains(listener.position, nearest_distance(plate, listener))
            output = _pressure_output(h * poles / -np.conj(poles), self.poles, ok, plate, listener)
        else:
            output = LISTENER_OUTPUTS[type(listener)](
                modes, plate, listener, self.poles, ok, sigma, omega, wd
            )
        return dataclasses.replace(self, listener=output)

    def direct(self, excitation) -> np.ndarray | None:
        """``phi_k(xp) b_k`` of an accelerometer's direct term ``b_k F(t)`` (None for a
        microphone)."""
        return None if self.listener.shape is None else self.listener.shape * excitation


def modal_model(
    plate,
    listener,
    *,
    samplerate: int,
    max_frequency: float | None = None,
    radiation_max_points: int | None = None,
) -> ModalModel:
    """The :class:`ModalModel` of ``plate`` heard by ``listener`` (an Accelerometer or a
    Microphone) at ``samplerate`` Hz, modes up to ``max_frequency`` Hz (default Nyquist;
    a mode at or above Nyquist is never rendered). Plate modes and microphone gains come
    from their caches when present.

    A mode with sigma >= omega is overdamped: it does not ring (possible only for a loss
    factor >= 2, or a Rayleigh law far outside any material's range); it is left out and
    counted. ``radiation_max_points``: the most points of one rule of a microphone's
    sums (:attr:`synth.cost.RadiationWork.max_points`: where the budget stops the
    refinement; None: the sums' own default).
    """
    fs = samplerate
    f_max = 0.5 * fs if max_frequency is None else max_frequency
    modes = plate_modes.modes(plate, max_frequency=f_max * (1.0 - 1e-9))
    sigma, omega, wd = _mode_rates(modes)
    under = sigma < omega
    ok = under & (wd < math.pi * fs)
    poles = (-sigma + 1j * wd)[ok]
    gains = LISTENER_OUTPUTS[type(listener)](
        modes, plate, listener, poles, ok, sigma, omega, wd, radiation_max_points
    )
    return ModalModel(modes, poles, ok, gains, int(np.sum(~under)), int(fs))


def _mode_rates(modes):
    """``(sigma, omega, omega_d)`` of every mode, rad/s: decay rate, undamped and damped
    angular frequency (0 for an overdamped mode)."""
    sigma = np.asarray(modes.decay_rates, dtype=float)
    omega = np.asarray(modes.angular_frequencies, dtype=float)
    under = sigma < omega
    wd = np.zeros_like(omega)  # an overdamped mode's sigma can be of any size: not squared
    wd[under] = np.sqrt(omega[under] ** 2 - sigma[under] ** 2)
    return sigma, omega, wd


def listener_grid(model: ModalModel, max_bytes: int | None = None):
    """The :class:`~synth.sound.radiation.fixed.ListenerGrid` of ``model``'s plate: its
    microphone gains at any point at least
    :data:`~synth.sound.radiation.fixed.NEAR_FIELD_HEIGHT` above the plate at the cost of
    the sums alone (:meth:`ModalModel.heard_by`); it keeps the modes' shapes on its grids
    (:attr:`~synth.sound.radiation.fixed.ListenerGrid.nbytes`; a
    :class:`~synth.sound.radiation.fixed.GridTooLarge` error beyond ``max_bytes``, bytes,
    default :data:`~synth.sound.radiation.fixed.MAX_GRID_BYTES`)."""
    from synth.sound.radiation.fixed import ListenerGrid

    sigma, omega, wd = _mode_rates(model.modes)
    return ListenerGrid(
        model.modes,
        -np.conj(_sum_poles(sigma, omega, wd, model.rendered)),
        max_wavenumber=_max_wavenumber(model.modes.plate, omega[model.rendered]),
        air_density=AIR_DENSITY,
        sound_speed=SOUND_SPEED,
        max_bytes=max_bytes,
    )


#: The render options a preset's ``[render]`` section may set (with ``subtype``, the
#: output file's, see :func:`synth.io.audio.write_audio`).
OPTIONS = (
    "samplerate",
    "normalize",
    "peak_db",
    "loudness_lufs",
    "floor_db",
    "max_frequency",
    "preroll",
    "fade",
    "max_duration",
    "max_tail",
    "pulse_points",
    "bounce_floor_db",
    "max_impacts",
)


#: Longest preroll and fade, s.
MAX_PREROLL = 10.0
#: Longest bounce series and tail, s each (10 minutes each: the longest render, 20 minutes,
#: is a float64 buffer of 3.7 GB at 384 kHz, 0.46 GB at 48 kHz).
MAX_DURATION = 600.0
#: Lowest peak level and loudness, dBFS and LUFS: a peak at -120 dBFS spans a few levels
#: of a 24-bit file (its step is 2^-23, -138 dBFS); below it the file is silence.
MIN_LEVEL_DB = -120.0
#: Most points of a pulse's grid: the rule's error falls as ``n^-2.5`` (see
#: :mod:`synth.sound.modal_bank`) from 2e-6 of the impulse at 65 points, so at 4097 it is
#: below 1e-10, far under float32 audio's resolution (6e-8); more points only cost time.
MAX_PULSE_POINTS = 4097
#: Relative agreement of a passed sequence's first contact with the scene's own (the
#: solver's tolerance is far tighter; another ball or plate differs by percents).
SEQUENCE_RTOL = 1e-4
#: Most impacts a render's bounce series may be given (``max_impacts``): each impact is a
#: contact solve and a pulse, so this many is minutes of work; a guard against a typo.
MAX_IMPACTS = 100_000


def check_options(
    *,
    samplerate,
    normalize="peak",
    peak_db=-1.0,
    loudness_lufs=-23.0,
    floor_db=-80.0,
    max_frequency=None,
    preroll=0.005,
    fade=0.005,
    max_duration=30.0,
    max_tail=60.0,
    pulse_points=PULSE_POINTS,
    bounce_floor_db=DEFAULT_FLOOR_DB,
    max_impacts=DEFAULT_MAX_IMPACTS,
) -> dict:
    """Check the options of :func:`render` (units and ranges there) and return them
    converted (floats, an int rate); a bad one is a ``ParameterError`` naming it, its
    value and what is allowed. Used by :func:`render` itself and by presets."""
    fs = _samplerate(samplerate)
    checks.choice("normalize", normalize, NORMALIZE)
    peak = checks.real("peak_db", peak_db, "dBFS", "<= 0")
    if not peak <= 0.0:
        raise ParameterError(f"peak_db={peak_db!r} must be <= 0 (dBFS)")
    lufs = checks.real("loudness_lufs", loudness_lufs, "LUFS", "< 0")
    if not lufs < 0.0:
        raise ParameterError(f"loudness_lufs={loudness_lufs!r} must be < 0 (LUFS)")
    floor = checks.real("floor_db", floor_db, "dB", "< 0")
    if not floor < 0.0:
        raise ParameterError(f"floor_db={floor_db!r} must be < 0 (dB)")
    f_max = None
    if max_frequency is not None:
        f_max = checks.positive("max_frequency", max_frequency, "Hz")
        if f_max > 0.5 * fs:
            raise ParameterError(
                f"max_frequency={max_frequency!r} must be <= the Nyquist frequency "
                f"{0.5 * fs:g} Hz at samplerate={fs} (Hz)"
            )
    if (
        isinstance(pulse_points, bool)
        or not isinstance(pulse_points, (int, np.integer))
        or not 5 <= pulse_points <= MAX_PULSE_POINTS
    ):
        raise ParameterError(
            f"pulse_points={pulse_points!r} must be an integer in [5, {MAX_PULSE_POINTS}]"
        )
    bounce_floor = checks.real("bounce_floor_db", bounce_floor_db, "dB", "< 0")
    if not bounce_floor < 0.0:
        raise ParameterError(
            f"bounce_floor_db={bounce_floor_db!r} must be < 0 (dB: an impact's kinetic "
            f"energy re the first impact's)"
        )
    if (
        isinstance(max_impacts, bool)
        or not isinstance(max_impacts, (int, np.integer))
        or not 1 <= max_impacts <= MAX_IMPACTS
    ):
        raise ParameterError(
            f"max_impacts={max_impacts!r} must be an integer in [1, {MAX_IMPACTS}]"
        )
    if peak < MIN_LEVEL_DB:
        raise ParameterError(f"peak_db={peak_db!r} must be in [{MIN_LEVEL_DB:g}, 0] (dBFS)")
    if lufs < MIN_LEVEL_DB:
        raise ParameterError(
            f"loudness_lufs={loudness_lufs!r} must be in [{MIN_LEVEL_DB:g}, 0) (LUFS)"
        )
    return dict(
        samplerate=fs,
        normalize=normalize,
        peak_db=peak,
        loudness_lufs=lufs,
        floor_db=floor,
        max_frequency=f_max,
        preroll=_seconds("preroll", preroll, MAX_PREROLL, lo_open=False),
        fade=_seconds("fade", fade, MAX_PREROLL, lo_open=False),
        max_duration=_seconds("max_duration", max_duration, MAX_DURATION),
        max_tail=_seconds("max_tail", max_tail, MAX_DURATION),
        pulse_points=int(pulse_points),
        bounce_floor_db=bounce_floor,
        max_impacts=int(max_impacts),
    )


def bounce_options(options: dict) -> dict:
    """The options of :func:`synth.physics.bounces.simulate_scene` that checked render
    ``options`` (:func:`check_options`) set: the series' duration, level and impact
    rules, one place for every caller that computes a render's bounces."""
    return dict(
        max_duration=options["max_duration"],
        floor_db=options["bounce_floor_db"],
        max_impacts=options["max_impacts"],
    )


def _seconds(name, value, hi, lo_open=True) -> float:
    if lo_open:
        return checks.positive_at_most(name, value, hi, "s")
    x = checks.nonnegative(name, value, "s")
    if x > hi:
        raise ParameterError(f"{name}={value!r} must be >= 0 and <= {hi:g} (s)")
    return x


def _silent_plate_message(f_max: float, samplerate: int, plate=None, overdamped: int = 0) -> str:
    """Why a plate without a mode below ``f_max`` (Hz) is refused, and what can change:
    the damping law when every mode there is ``overdamped`` (they do not ring; ``plate``
    names it), else ``max_frequency`` only while it is below the Nyquist frequency."""
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


def check_sequence(scene, sequence) -> BounceSequence:
    """``sequence`` as the impacts of ``scene``: a non-empty :class:`BounceSequence` whose
    contacts are ``scene``'s (its first impact solved again with the scene's ball, plate,
    impact point and contact law at the same speed gives the same contact time and peak
    force to within ``SEQUENCE_RTOL``). The impacts' times and speeds may come from
    another scene (:func:`synth.stimuli.sequences.mismatch_sequence`). With the modal plate
    in the contact an impact depends on the ringing left by the ones before, so there the
    first impact's contact law (stiffness, exponent and loss of the scene's ball and plate)
    is what is checked."""
    from synth.physics import contact

    if not isinstance(sequence, BounceSequence):
        raise ParameterError(f"sequence={sequence!r} must be a BounceSequence")
    if not len(sequence):
        raise ParameterError("sequence has no impacts: there is nothing to render")
    first = sequence[0]
    from synth.physics.plate_choice import scene_plate

    c = scene.contact
    if scene_plate(scene).plate == "modal":
        return _check_modal_sequence(scene, sequence)
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
    """:func:`check_sequence` for a scene with the modal plate in the contact: the first
    impact is one of the modal contact (:class:`~synth.physics.modal_contact.ModalImpactResult`)
    under the scene's contact law (its constants equal to ``SEQUENCE_RTOL``)."""
    from synth.physics.contact_law import contact_parameters
    from synth.physics.modal_contact import ModalImpactResult

    c = scene.contact
    result = sequence[0].result
    law = contact_parameters(scene.ball, scene.plate, c.law, **c.options())
    want = (law.stiffness, law.exponent, law.dissipation, law.viscous_time)
    got = (
        (
            result.law_stiffness,
            result.law_exponent,
            result.law_dissipation,
            result.law_viscous_time,
        )
        if isinstance(result, ModalImpactResult)
        else None
    )
    if got is None or not all(
        abs(a - b) <= SEQUENCE_RTOL * abs(b) for a, b in zip(got, want, strict=True)
    ):
        K, n, mu, A = want
        raise ParameterError(
            "sequence: its first impact is not one of this scene's modal contact (contact law "
            f"K, n, mu, A = {K:.6g}, {n:g}, {mu:g}, {A:g}): the sequence belongs to another "
            "ball, plate or contact law; pass the scene it was computed for"
        )
    return sequence


def render(
    scene,
    *,
    samplerate,
    normalize="peak",
    peak_db=-1.0,
    loudness_lufs=-23.0,
    floor_db=-80.0,
    max_frequency=None,
    preroll=0.005,
    fade=0.005,
    max_duration=30.0,
    max_tail=60.0,
    sequence=None,
    pulse_points=PULSE_POINTS,
    bounce_floor_db=DEFAULT_FLOOR_DB,
    max_impacts=DEFAULT_MAX_IMPACTS,
    budget=None,
) -> Render:
    """Render ``scene`` at ``samplerate``.

    Parameters
    ----------
    scene : Scene
    samplerate : int
        Hz, in [8000, 384000]. Required: there is no default or global rate.
    normalize : {"peak", "loudness", "physical", "none"}
        Level stage: peak to ``peak_db`` dBFS; integrated loudness to ``loudness_lufs``
        LUFS (needs pyloudnorm); a fixed physical calibration (see
        :mod:`synth.io.audio`); or none (audio in Pa or m/s^2).
    peak_db : float in [-120, 0]
        dBFS for "peak".
    loudness_lufs : float in [-120, 0)
        LUFS for "loudness" (integrated, ITU-R BS.1770).
    floor_db : float < 0
        Omission floor, dB below the reference amplitude (the bound on the loudest tick's
        peak): omitted modes and tails add up to at most this (see :mod:`synth.sound.modal_bank`).
    max_frequency : float > 0, optional
        Highest mode rendered, Hz, at most the Nyquist frequency ``samplerate / 2``
        (default: the Nyquist frequency; a mode at or above it is never rendered). A value
        below the plate's lowest mode is refused (the render would be silent).
    preroll : float in [0, 10]
        Silence before the first tick, s.
    fade : float in [0, 10]
        Raised-cosine fade at the end, s (the tail there is already below the floor); a
        fade longer than the audio is refused.
    max_duration : float in (0, 600]
        Longest bounce series, s from release; the first impact must fall inside it.
    max_tail : float in (0, 600]
        Longest ringing after the last impact, s: the audio ends when every tail has
        fallen below the floor, or at this limit (lightly damped plates, e.g. steel with
        a loss factor of 1e-4, ring for minutes). A tail cut here is reported in
        ``settings["tail_cut"]`` and ``settings["left_at_end"]`` (the bound, relative to
        the reference amplitude, of what rings on after the end).
    sequence : BounceSequence, optional
        Precomputed impacts of this scene (default: computed here); not empty, and its
        contacts must be this scene's (see :func:`check_sequence`).
    pulse_points : int in [5, 4097]
        Fewest points of the uniform grid on which each force pulse's Laplace
        transforms are taken (see :mod:`synth.sound.modal_bank`; the default keeps their error
        below 2e-6 of the impulse; a reference render may ask for more).
    bounce_floor_db : float < 0
        The bounce series' level rule (:func:`synth.physics.bounces.simulate_bounces`'s
        ``floor_db``): the series ends before an impact whose kinetic energy would be this
        many dB below the first impact's (``stop_reason`` "floor"). Not ``floor_db``,
        which bounds the synthesis' omissions.
    max_impacts : int in [1, 100000]
        The bounce series' impact limit: it ends after this many impacts
        (``stop_reason`` "max-impacts"), a stated stop for a ball that loses little per
        bounce. Both rules apply to a drop; a scene with ``drop.velocity`` follows its path
        until the ball rolls (:mod:`synth.physics.path`) and does not use them.
    budget : synth.cost.Budget, optional
        The most work the render may take on (default: ``Budget.from_environment()``):
        the scene's :func:`synth.cost.estimate` beyond it, or a contact longer than
        ``max_duration``, is refused before any work with a ``ParameterError`` naming
        what is too big and what to change.
    """
    if not isinstance(scene, Scene):
        raise ParameterError(f"scene={scene!r} must be a Scene")
    scene.plate.damping_law()  # before the bounces: the modes will need it
    disk_cache.check_environment()  # a bad $SYNTH_CACHE_* refused before any work
    o = check_options(
        samplerate=samplerate,
        normalize=normalize,
        peak_db=peak_db,
        loudness_lufs=loudness_lufs,
        floor_db=floor_db,
        max_frequency=max_frequency,
        preroll=preroll,
        fade=fade,
        max_duration=max_duration,
        max_tail=max_tail,
        pulse_points=pulse_points,
        bounce_floor_db=bounce_floor_db,
        max_impacts=max_impacts,
    )
    fs = o["samplerate"]
    floor = 10.0 ** (o["floor_db"] / 20.0)
    f_max = 0.5 * fs if o["max_frequency"] is None else o["max_frequency"]
    pre, tail, fade_s = o["preroll"], o["max_tail"], o["fade"]
    max_duration = o["max_duration"]
    if sequence is None:
        first_touch = math.sqrt(2.0 * scene.drop_height / scene.gravity)
        if first_touch > max_duration:
            raise ParameterError(
                f"drop.height={scene.drop_height!r} m: the first impact, {first_touch:.4g} s "
                f"after release, is later than max_duration={max_duration!r} (s)"
            )
    if budget is None:
        budget = cost.Budget.from_environment()
    elif not isinstance(budget, cost.Budget):
        raise ParameterError(f"budget={budget!r} must be a synth.cost.Budget")
    estimate = cost.estimate(
        scene, samplerate=fs, max_frequency=f_max, preroll=pre, max_duration=max_duration,
        max_tail=tail, pulse_points=int(pulse_points), floor_db=o["floor_db"], budget=budget,
    )  # fmt: skip
    estimate.check(budget)
    if scene.moving:
        if sequence is not None:
            raise ParameterError(
                "sequence: a scene with drop.velocity computes its own path (bounces and "
                "rolling); pass no sequence"
            )
        return _render_moving(scene, o)
    if sequence is None:
        sequence = simulate_scene(scene, **bounce_options(o))
    else:
        check_sequence(scene, sequence)
    for imp in sequence:
        if not imp.result.success:
            raise SynthError(
                f"impact {imp.index} (at {imp.speed:.4g} m/s) could not be solved: "
                f"{imp.result.message} The scene is outside what the contact solver handles"
            )

    model = modal_model(
        scene.plate,
        scene.listener,
        samplerate=fs,
        max_frequency=f_max,
        radiation_max_points=estimate.radiation.max_points,
    )
    poles = model.poles
    excitation = model.excitation(scene.position)
    output = model.output
    direct = model.direct(excitation)
    delay = model.delay
    units = model.units
    if not poles.size:
        raise ParameterError(_silent_plate_message(f_max, fs, scene.plate, model.n_overdamped))
    listener = scene.listener

    times = np.array([imp.time for imp in sequence])
    start = (times[0] + delay - pre) if len(times) else 0.0
    onsets = times + delay - start
    weights = [scene.ball.mass * scene.gravity if imp.result.settled else 0.0 for imp in sequence]
    max_samples = int(math.ceil((sequence.duration + delay - start + tail) * fs))
    audio, info = synthesize(
        [imp.result for imp in sequence],
        onsets,
        poles,
        excitation,
        output,
        fs,
        floor=floor,
        settled_weight=weights,
        direct=direct,
        max_samples=max_samples,
        pulse_points=int(pulse_points),
    )
    _fade(audio, fade_s, fs)
    from synth.io import audio as audio_io

    scaled, gain = audio_io.normalize(
        audio, normalize, samplerate=fs, units=units, peak_db=peak_db, loudness_lufs=loudness_lufs
    )
    settings = dict(
        samplerate=fs,
        normalize=normalize,
        peak_db=peak_db,
        loudness_lufs=loudness_lufs,
        floor_db=floor_db,
        max_frequency=f_max,
        preroll=pre,
        fade=fade_s,
        max_tail=tail,
        bounce_floor_db=o["bounce_floor_db"],
        max_impacts=o["max_impacts"],
        listener=type(listener).__name__.lower(),
        listener_position=list(listener.position),
        delay=delay,
        audio_start=start,
        n_impacts=len(sequence),
        stop_reason=sequence.stop_reason,
        n_modes=int(poles.size),
        n_modes_rendered=info["n_modes_rendered"],
        mode_samples=info["mode_samples"],
        n_modes_overdamped=model.n_overdamped,
        tail_cut=bool(
            info["length"] >= max_samples and info["left_at_end"] > floor * info["reference"]
        ),
        left_at_end=info["left_at_end"] / info["reference"] if info["reference"] else 0.0,
        bank_seconds=info["bank_seconds"],
        reference_amplitude=info["reference"],
    )
    return Render(np.asarray(scaled, dtype=np.float32), fs, sequence, units, float(gain), settings)


def _render_moving(scene, o) -> Render:
    """:func:`render` of a scene with a horizontal velocity: its bounces and rolling
    (:mod:`synth.sound.path_render`), faded and levelled as every render."""
    from synth.io import audio as audio_io
    from synth.sound.path_render import render_path_audio

    fs = o["samplerate"]
    f_max = 0.5 * fs if o["max_frequency"] is None else o["max_frequency"]
    model = modal_model(scene.plate, scene.listener, samplerate=fs, max_frequency=f_max)
    if not model.poles.size:
        raise ParameterError(_silent_plate_message(f_max, fs, scene.plate, model.n_overdamped))
    audio, path, extra = render_path_audio(scene, model, o)
    _fade(audio, o["fade"], fs)
    scaled, gain = audio_io.normalize(
        audio, o["normalize"], samplerate=fs, units=model.units, peak_db=o["peak_db"],
        loudness_lufs=o["loudness_lufs"],
    )  # fmt: skip
    settings = dict(
        samplerate=fs,
        normalize=o["normalize"],
        peak_db=o["peak_db"],
        loudness_lufs=o["loudness_lufs"],
        floor_db=o["floor_db"],
        max_frequency=f_max,
        preroll=o["preroll"],
        fade=o["fade"],
        max_tail=o["max_tail"],
        listener=type(scene.listener).__name__.lower(),
        listener_position=list(scene.listener.position),
        n_impacts=len(path.impacts),
        stop_reason=path.impacts.stop_reason,
        n_modes=int(model.poles.size),
        n_modes_overdamped=model.n_overdamped,
        **extra,
    )
    return Render(
        np.asarray(scaled, dtype=np.float32), fs, path.impacts, model.units, float(gain), settings
    )


def _fade(audio, fade_s, fs) -> None:
    """A raised-cosine fade of ``fade_s`` s at the end of ``audio`` (in place); refused if
    longer than the audio."""
    from synth.io import audio as audio_io

    if fade_s > audio.size / fs:
        raise ParameterError(
            f"fade={fade_s!r} s is longer than the audio "
            f"({audio.size / fs:.6g} s); it must be at most that"
        )
    if fade_s > 0 and audio.size:
        # the fade's n frames run from full level (the first) to 0 (the last)
        n = min(audio.size, int(round(fade_s * fs)))
        audio_io.apply_fade_out(audio, n - 1)
