"""``synth bench rollingcheck``: the rolling's validation figures (docs/validation.md,
"Rolling").

* The speed at which a ball rolling on a sinusoid starts to lose contact, found by
  :func:`synth.physics.rolling.loss_of_contact_speed`, against the closed form
  ``sqrt(g (1 / (A k^2) + R))`` and the point follower's ``sqrt(g / (A k^2))``.
* The energy balance of rolling over a rough surface: without loss (elastic Hertz on a rigid
  plate), into the plate's impedance, with the Hunt-Crossley loss, and along a preset's path
  with Coulomb's rolling resistance (:class:`synth.physics.path.RollingEnergy`).
* The spectral centroid of the contact force and of the plate's acceleration as the speed
  rises over one rough surface, and as the ball's size grows (the envelope smooths more of
  the roughness under a larger ball, and its resting contact's natural frequency,
  ``omega_c^2 = (3/2) g / delta_static`` with ``delta_static ~ R^(5/3)``, falls as
  ``R^(-5/6)``).

* The rolling sound against speed and ball size beside the published measurement of
  Houben, Kohlrausch & Hermes (2004), who recorded wooden balls rolling on a wooden plate
  with a microphone (:data:`HOUBEN_2004`): oak balls on an MDF plate of the measured MDF
  roughness (:data:`synth.physics.surface.MEASURED_ROUGHNESS`), heard by a microphone above
  it; the sound's spectral centroid and level at each speed and size.

The rough surface of the first checks (Matern: rms 1 um, correlation length 100 um, Hurst
exponent 0.8) and the Hunt-Crossley loss (0.1 s/m) are inputs of this check, not published
values; so are the balls' radii and speeds of the published comparison. Nothing here is
timed.
"""

from __future__ import annotations

import math

SAMPLERATE = 48000
#: The sinusoid of the contact-loss check: amplitude and wavelength, m.
AMPLITUDE, WAVELENGTH = 2e-5, 5e-3
#: Speeds of the centroid check, m/s.
CENTROID_SPEEDS = (0.05, 0.1, 0.2, 0.4)
#: Radii of the size check, m, and its speeds, m/s.
SIZE_RADII = (0.0025, 0.005, 0.01)
SIZE_SPEEDS = (0.1, 0.2)
#: Length of each rolling of the energy and centroid checks, s.
ROLL_SECONDS = 0.5
#: Hunt-Crossley damping of the lossy energy case, s/m (an input of the check).
HUNT_CROSSLEY = 0.1
#: The published measurement the rolling sound is set beside: its source and what it reports
#: of the recorded sound as the speed and the ball's size grow (directions only: the
#: engine holds no figure of the paper's to compare number with number).
HOUBEN_2004 = dict(
    source="Houben, Kohlrausch & Hermes (2004), Speech Communication 43, 331-345: wooden "
    "balls rolling on a wooden plate, recorded with a microphone",
    speed="the spectrum shifts up (higher spectral centroid) and the sound grows louder",
    size="a larger ball's spectrum lies lower (lower spectral centroid)",
)
#: Speeds (m/s), oak balls' radii (m) and length of each rolling (s) of the published
#: comparison (inputs of the check).
PUBLISHED_SPEEDS = (0.1, 0.2, 0.4)
PUBLISHED_RADII = (0.005, 0.01, 0.02)
PUBLISHED_SECONDS = 0.5
#: Rough profiles (of the one measured spectrum) each figure is the mean over.
PUBLISHED_PROFILES = 8


def _pair():
    from synth.physics.scene import Ball, Plate

    return Ball("steel", 0.005), Plate("glass", 0.006, 1.0, 0.6, boundary="simply-supported")


def _rough_envelope(radius, length=0.5):
    from synth.physics import surface

    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=1e-4, hurst=0.8)
    profile = surface.rough_profile(spec, length=length, spacing=5e-6, seed=1)
    return surface.contact_envelope(profile, radius)


def contact_loss_rows() -> list[dict]:
    """Contact-loss speed on the sinusoid for a 10 mm and a 2 mm steel ball (rigid plate)."""
    from synth.physics import rolling, surface
    from synth.physics.scene import Ball

    _, plate = _pair()
    k = 2.0 * math.pi / WAVELENGTH
    rho = 1.0 / (AMPLITUDE * k * k)
    g = 9.81
    rows = []
    for radius in (0.01, 0.002):
        ball = Ball("steel", radius)
        profile = surface.sinusoidal_profile(
            amplitude=AMPLITUDE, wavelength=WAVELENGTH, length=0.1,
            spacing=WAVELENGTH / 200, phase=-math.pi / 2,
        )  # fmt: skip
        env = surface.contact_envelope(profile, radius)
        closed = math.sqrt(g * (rho + radius))
        roller = rolling.Roller.over(
            ball, plate, env, samplerate=SAMPLERATE, origin=(0.1, 0.3), admittance=0.0
        )
        found = rolling.loss_of_contact_speed(
            roller, start=WAVELENGTH, stop=4.5 * WAVELENGTH, low=0.9 * closed, high=1.05 * closed
        )
        rows.append(
            dict(
                diameter_mm=2e3 * radius,
                found=found.speed,
                closed_form=closed,
                point=math.sqrt(g * rho),
                success=found.success,
            )
        )
    return rows


def energy_rows() -> list[dict]:
    """Energy balances of rolling over the rough surface at 0.3 m/s, and of a preset's path."""
    from synth.io.presets import load_preset
    from synth.physics import rolling
    from synth.physics.path import simulate_path

    ball, plate = _pair()
    env = _rough_envelope(ball.radius)
    cases = (
        ("elastic, rigid plate", dict(admittance=0.0)),
        ("elastic, plate impedance", {}),
        ("Hunt-Crossley, rigid plate", dict(admittance=0.0, contact="hunt-crossley",
                                            dissipation=HUNT_CROSSLEY)),
    )  # fmt: skip
    rows = []
    for name, options in cases:
        r = rolling.roll(
            ball, plate, env, speed=0.3, duration=ROLL_SECONDS, samplerate=SAMPLERATE,
            origin=(0.2, 0.3), start=0.01, **options,
        )  # fmt: skip
        e = r.energy
        rows.append(
            dict(
                case=name,
                supplied=e.drive_work,
                change=e.final - e.initial,
                loss=e.loss_work,
                plate=e.plate_energy,
                resistance=0.0,
                residual=e.residual,
            )
        )
    preset = "thesis-steel10-mdf18-rolling"
    path = simulate_path(load_preset(preset), samplerate=SAMPLERATE, time_origin=0.0)
    e = path.rolling.energy
    rows.append(
        dict(
            case=f"path of {preset} (C_rr)",
            supplied=0.0,
            change=e.final - e.initial,
            loss=e.contact_loss,
            plate=e.plate_energy,
            resistance=e.resistance_work,
            residual=e.residual,
        )
    )
    return rows


def spectral_centroid(signal, samplerate) -> float:
    """The power spectrum's centroid, Hz (the signal's mean removed)."""
    import numpy as np

    x = np.asarray(signal, dtype=float) - np.mean(signal)
    power = np.abs(np.fft.rfft(x * np.hanning(x.size))) ** 2
    f = np.fft.rfftfreq(x.size, 1.0 / samplerate)
    return float(np.sum(f * power) / np.sum(power))


def centroid_rows(speeds=CENTROID_SPEEDS, seconds=ROLL_SECONDS, radii=None) -> list[dict]:
    """Centroids of the force and of an accelerometer's signal at each speed (m/s), for the
    steel ball of each of ``radii`` (m; default the 5 mm radius of the other checks)."""
    from synth.physics import rolling
    from synth.physics.scene import Accelerometer, Ball
    from synth.sound import rolling as sound
    from synth.sound.render import modal_model

    ball, plate = _pair()
    model = modal_model(plate, Accelerometer((0.5, 0.2)), samplerate=SAMPLERATE)
    rows = []
    for radius in (ball.radius,) if radii is None else radii:
        ball = Ball("steel", radius)
        env = _rough_envelope(radius)
        for v in speeds:
            r = rolling.roll(
                ball, plate, env, speed=v, duration=seconds, samplerate=SAMPLERATE,
                origin=(0.2, 0.3), start=0.015,
            )  # fmt: skip
            audio = sound.rolling_sound(r, model)
            rows.append(
                dict(
                    radius=radius,
                    speed=v,
                    force_centroid=spectral_centroid(r.force, SAMPLERATE),
                    acceleration_centroid=spectral_centroid(audio, SAMPLERATE),
                    flights=r.flights,
                )
            )
    return rows


def published_rows(
    speeds=PUBLISHED_SPEEDS, radii=PUBLISHED_RADII, seconds=PUBLISHED_SECONDS,
    profiles=PUBLISHED_PROFILES,
) -> list[dict]:  # fmt: skip
    """The rolling sound of an oak ball of each of ``radii`` (m) at each of ``speeds``
    (m/s) for ``seconds`` s on an 18 mm MDF plate of the measured MDF roughness, heard by a
    microphone 0.3 m above its centre (:data:`HOUBEN_2004`'s setting, wood on wood): the
    sound's spectral centroid (Hz) and RMS level (dB re 1 Pa), each the mean over
    ``profiles`` rough profiles of the one spectrum (seeds 1, 2, ...), with their standard
    deviations over them (``centroid_spread``, ``level_spread``)."""
    import numpy as np

    from synth.physics import surface
    from synth.physics.scene import Microphone, Plate
    from synth.sound.render import modal_model

    plate = Plate("mdf-18", thickness=0.018, length=1.2, width=0.6)
    model = modal_model(plate, Microphone((0.6, 0.3, 0.3)), samplerate=SAMPLERATE)
    spectrum = surface.MEASURED_ROUGHNESS["mdf"].spectrum()
    length = max(speeds) * seconds + 0.05
    draws = [
        surface.rough_profile(spectrum, length=length, spacing=5e-6, seed=seed)
        for seed in range(1, profiles + 1)
    ]
    rows = []
    for radius in radii:
        envelopes = [surface.contact_envelope(profile, radius) for profile in draws]
        for v in speeds:
            found = np.array(
                [_sound_figures(radius, v, e, plate, model, seconds) for e in envelopes]
            )
            rows.append(
                dict(
                    radius=radius,
                    speed=v,
                    centroid=float(found[:, 0].mean()),
                    centroid_spread=float(found[:, 0].std()),
                    level=float(found[:, 1].mean()),
                    level_spread=float(found[:, 1].std()),
                    profiles=profiles,
                )
            )
    return rows


def _sound_figures(radius, speed, envelope, plate, model, seconds) -> tuple[float, float]:
    """The spectral centroid (Hz) and RMS level (dB re the model's unit) of an oak ball of
    ``radius`` (m) rolling at ``speed`` (m/s) over ``envelope`` for ``seconds`` s."""
    import numpy as np

    from synth.physics import rolling
    from synth.physics.scene import Ball
    from synth.sound import rolling as sound

    r = rolling.roll(
        Ball("oak", radius), plate, envelope, speed=speed, duration=seconds,
        samplerate=SAMPLERATE, origin=(0.2, 0.3), start=0.015,
    )  # fmt: skip
    audio = sound.rolling_sound(r, model)
    return spectral_centroid(audio, SAMPLERATE), float(20.0 * np.log10(np.sqrt(np.mean(audio**2))))


def run_rolling_check() -> dict:
    """Every figure of the module docstring."""
    return {
        "contact_loss": contact_loss_rows(),
        "energy": energy_rows(),
        "centroid": centroid_rows(),
        "size": centroid_rows(speeds=SIZE_SPEEDS, radii=SIZE_RADII),
        "published": published_rows(),
    }


def format_rolling_check(result: dict) -> str:
    """Markdown tables of :func:`run_rolling_check`."""
    lines = [
        "Speed at which contact starts to be lost on h = A sin(k x) (A = 20 um, wavelength "
        "5 mm; steel ball on a rigid glass plate):",
        "",
        "| ball mm | found m/s | sqrt(g (rho + R)) m/s | off | point follower sqrt(g rho) m/s "
        "| off |",
        "|---|---|---|---|---|---|",
    ]
    for r in result["contact_loss"]:
        lines.append(
            f"| {r['diameter_mm']:.0f} | {r['found']:.4f} | {r['closed_form']:.4f} | "
            f"{100 * (r['found'] / r['closed_form'] - 1):+.2f} % | {r['point']:.4f} | "
            f"{100 * (r['found'] / r['point'] - 1):+.1f} % |"
        )
    lines += [
        "",
        "Energy balance (J): what the horizontal drive supplied, the change of the mechanical "
        "energy (for the path: of the rolling sphere's and the vertical one), what the "
        "contact's loss, the plate and the rolling resistance took, and the residual "
        "relative to the largest term:",
        "",
        "| case | supplied | change | contact loss | into the plate | resistance | residual |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in result["energy"]:
        lines.append(
            f"| {r['case']} | {r['supplied']:.3e} | {r['change']:.3e} | {r['loss']:.3e} | "
            f"{r['plate']:.3e} | {r['resistance']:.3e} | {r['residual']:.1e} |"
        )
    lines += [
        "",
        "Spectral centroid (Hz) of the contact force and of an accelerometer's signal, 10 mm "
        "steel ball on rough 6 mm glass, 0.5 s at each speed:",
        "",
        "| speed m/s | force centroid Hz | acceleration centroid Hz | flights |",
        "|---|---|---|---|",
    ]
    for r in result["centroid"]:
        lines.append(
            f"| {r['speed']:.2f} | {r['force_centroid']:.0f} | "
            f"{r['acceleration_centroid']:.0f} | {r['flights']} |"
        )
    lines += [
        "",
        "The same against the ball's size (steel balls, 0.5 s at each speed):",
        "",
        "| radius mm | speed m/s | force centroid Hz | acceleration centroid Hz | flights |",
        "|---|---|---|---|---|",
    ]
    for r in result["size"]:
        lines.append(
            f"| {1e3 * r['radius']:.1f} | {r['speed']:.2f} | {r['force_centroid']:.0f} | "
            f"{r['acceleration_centroid']:.0f} | {r['flights']} |"
        )
    return "\n".join(lines + _published_lines(result.get("published")))


def _published_lines(rows) -> list[str]:
    """The published comparison (:func:`published_rows`) as Markdown lines: the engine's
    centroid and level at each speed and size, and its change from the row before beside
    the published direction."""
    if not rows:
        return []
    lines = [
        "",
        f"The rolling sound beside a published measurement ({HOUBEN_2004['source']}): oak "
        "balls on 18 mm MDF of the measured MDF roughness, a microphone 0.3 m above, "
        f"{PUBLISHED_SECONDS:g} s at each speed; each figure the mean over "
        f"{PUBLISHED_PROFILES} rough profiles of the one spectrum (the centroid's standard "
        "deviation over them in brackets). Published, with the speed: "
        f"{HOUBEN_2004['speed']}; with the size: {HOUBEN_2004['size']}.",
        "",
        "| radius mm | speed m/s | engine centroid Hz (spread) | engine level dB re 1 Pa | "
        "engine, speed doubled | published, speed doubled |",
        "|---|---|---|---|---|---|",
    ]
    previous = None
    for r in rows:
        change = "-"
        if previous is not None and previous["radius"] == r["radius"]:
            change = (
                f"centroid {100 * (r['centroid'] / previous['centroid'] - 1):+.0f} %, level "
                f"{r['level'] - previous['level']:+.1f} dB"
            )
        published = "higher, louder" if change != "-" else "-"
        lines.append(
            f"| {1e3 * r['radius']:.0f} | {r['speed']:.2f} | {r['centroid']:.0f} "
            f"({r['centroid_spread']:.0f}) | {r['level']:.1f} | {change} | {published} |"
        )
        previous = r
    lines += [
        "",
        "| speed m/s | engine centroid Hz by radius (mm) | published, larger ball |",
        "|---|---|---|",
    ]
    for v in sorted({r["speed"] for r in rows}):
        by_size = ", ".join(
            f"{r['centroid']:.0f} ({1e3 * r['radius']:.0f})" for r in rows if r["speed"] == v
        )
        lines.append(f"| {v:.2f} | {by_size} | lower |")
    return lines
