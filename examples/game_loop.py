"""A small game loop: balls fall on a table at random places and heights, and every landing
sounds as the physics says.

The game owns the motion (free fall, a bounce that keeps half the speed); the engine owns the
sound: on each landing the loop calls ``body.hit(ball, speed, position=...)`` from the game
thread, and the impact sounds one audio block (plus the output latency) later. Each landing
is a voice of the table (a ``synth.Voice``: a modal state of its own); when more than the
engine's ``max_voices`` ring at once, a new landing steals the oldest, which fades out. The
player's head sits above the table's near edge, facing along it, and each ear hears the
table through its own Rayleigh gains (stereo from the physics). The game's own loop runs in
Python; the audio thread does not, so the loop cannot starve it. Run it with a sound device:

    python examples/game_loop.py --seconds 10

or without one, on the engine's own clock, writing what it would have played:

    python examples/game_loop.py --seconds 5 --offline game.wav
"""

import argparse
import time
from dataclasses import dataclass

import numpy as np

import synth

FPS = 60
GRAVITY = 9.81  # m/s^2
BOUNCE = 0.5  # the game's restitution (the sound uses the contact physics)
TABLE = synth.Plate("mdf-18", thickness=0.018, length=1.2, width=0.6)
BALLS = [synth.Ball("steel", radius=0.005), synth.Ball("glass", radius=0.008)]


@dataclass
class Falling:
    ball: synth.Ball
    x: float
    y: float
    height: float  # m above the table (lowest point of the ball)
    velocity: float  # m/s, positive upward


def step(balls, body, dt, rng):
    """Advance the game by ``dt`` s: maybe drop a new ball, move the others, sound landings."""
    if rng.random() < 2.0 * dt:  # two new balls a second
        balls.append(
            Falling(
                BALLS[rng.integers(len(BALLS))],
                rng.uniform(0.1, 1.1),
                rng.uniform(0.1, 0.5),
                rng.uniform(0.05, 0.5),
                0.0,
            )
        )
    for b in list(balls):
        b.velocity -= GRAVITY * dt
        b.height += b.velocity * dt
        if b.height <= 0.0 and b.velocity < 0.0:
            speed = -b.velocity
            body.hit(b.ball, speed, position=(b.x, b.y), gain=1.0)
            b.height, b.velocity = 0.0, BOUNCE * speed
            if b.velocity < 0.05:  # at rest: leaves the game
                balls.remove(b)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--offline", metavar="OUT.wav", help="no device: write the session")
    args = parser.parse_args()
    rng = np.random.default_rng(7)
    engine = synth.Engine(samplerate=48000, blocksize=256, channels=2)
    head = synth.live.ears((0.6, -0.2, 0.4), facing=(0.0, 1.0))  # above the near edge
    body = engine.add(TABLE, listener=head, gain=10.0)
    balls: list[Falling] = []
    frames = int(args.seconds * FPS)
    if args.offline:
        chunks = []
        for _ in range(frames):  # the engine's clock is the game's
            step(balls, body, 1.0 / FPS, rng)
            chunks.append(engine.process(48000 // FPS))
        audio = np.concatenate(chunks)
        synth.write_audio(args.offline, audio, 48000)
        stats = engine.stats
        print(
            f"{args.offline}: {stats.impacts_played} impacts, {stats.voices_stolen} voices "
            f"stolen, {len(engine.ended())} ended, peak {abs(audio).max():.3f}"
        )
        return
    with engine:
        next_frame = time.perf_counter()
        for _ in range(frames):
            step(balls, body, 1.0 / FPS, rng)
            next_frame += 1.0 / FPS
            time.sleep(max(0.0, next_frame - time.perf_counter()))
        time.sleep(1.0)  # let the last ones ring
    print(engine.stats)


if __name__ == "__main__":
    main()
