"""Cost of the rolling contact per second of audio (python examples/rolling_benchmark.py).

A 10 mm steel ball rolling over a rough 6 mm glass plate (Matern roughness, given here for
the benchmark: rms 1 um, correlation length 100 um, Hurst 0.8; not published values) at
three speeds, 48 kHz; then its force driving the plate's modes below 5 kHz heard by an
accelerometer. Prints, per stage, the wall time per second of audio (best of three runs
after a warm-up that compiles the kernels) and the solver's steps per sample. Figures
depend on the machine and its load; quote them with both.
"""

from __future__ import annotations

import time

from synth.physics import rolling, surface
from synth.physics.scene import Accelerometer, Ball, Plate
from synth.sound import rolling as sound
from synth.sound.render import modal_model

FS = 48000
DURATION = 1.0


def best_of(fn, runs=3):
    best, value = float("inf"), None
    for _ in range(runs):
        t = time.perf_counter()
        value = fn()
        best = min(best, time.perf_counter() - t)
    return best, value


def main():
    ball = Ball("steel", 0.01)
    plate = Plate("glass", 0.006, 1.0, 0.6, boundary="simply-supported")
    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=1e-4, hurst=0.8)
    t_env, env = best_of(
        lambda: surface.contact_envelope(
            surface.rough_profile(spec, length=0.9, spacing=5e-6, seed=1), ball.radius
        ),
        runs=1,
    )
    print(f"profile + envelope, 0.9 m at 5 um: {t_env:.3f} s (first run, with compiling)")
    model = modal_model(plate, Accelerometer((0.3, 0.2)), samplerate=FS, max_frequency=5000.0)
    for speed in (0.1, 0.3, 0.8):

        def solve(speed=speed):
            return rolling.roll(
                ball, plate, env, speed=speed, duration=DURATION, samplerate=FS,
                origin=(0.05, 0.3), start=0.01,
            )  # fmt: skip

        solve()  # warm-up
        t_roll, r = best_of(solve)
        t_modes, _ = best_of(lambda r=r: sound.rolling_sound(r, model))
        print(
            f"v = {speed:.1f} m/s: contact {t_roll / DURATION * 1e3:.1f} ms per s of audio "
            f"({r.n_steps / r.force.size:.2f} steps/sample, {r.flights} flights); "
            f"{model.poles.size} modes {t_modes / DURATION * 1e3:.1f} ms per s of audio"
        )


if __name__ == "__main__":
    main()
