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

The rough surface (Matern: rms 1 um, correlation length 100 um, Hurst exponent 0.8) and the
Hunt-Crossley loss (0.1 s/m) are inputs of this check, not published values. Nothing here is
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
        found = rolling.loss_of_contact_speed(
            ball, plate, env, start=WAVELENGTH, stop=4.5 * WAVELENGTH, low=0.9 * closed,
            high=1.05 * closed, samplerate=SAMPLERATE, origin=(0.1, 0.3), admittance=0.0,
        )  # fmt: skip
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


def run_rolling_check() -> dict:
    """Every figure of the module docstring."""
    return {
        "contact_loss": contact_loss_rows(),
        "energy": energy_rows(),
        "centroid": centroid_rows(),
        "size": centroid_rows(speeds=SIZE_SPEEDS, radii=SIZE_RADII),
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
    return "\n".join(lines)
