"""A UI button that clicks with a physical impact.

Each press taps a 2 mm steel ball at 0.4 m/s on a small acrylic panel (12 x 6 cm, 3 mm):
the click is the panel's modes, heard by a microphone 30 cm away, started one audio block
(plus the output latency) after the press. Run it with a display and a sound device:

    python examples/ui_button.py

or, with neither, write three clicks to a file through the same engine:

    python examples/ui_button.py --offline clicks.wav
"""

import argparse

import synth

PANEL = synth.Plate("acrylic", thickness=0.003, length=0.12, width=0.06, boundary="free")
TIP = synth.Ball("steel", radius=0.002)
LISTENER = synth.Microphone((0.06, 0.03, 0.3))
GAIN = 3000.0  # 70 dB above the physical calibration (1000 Pa full scale): about -20 dBFS


def make_engine():
    engine = synth.Engine(samplerate=48000, blocksize=128)
    return engine, engine.add(PANEL, listener=LISTENER, gain=GAIN)


def click(body, at=None):
    """One press: the tip hits the middle of the panel."""
    body.hit(TIP, 0.4, position=(0.06, 0.03), at=at)


def run_window():
    import tkinter as tk

    engine, body = make_engine()
    with engine:  # the stream stays open while the window lives
        root = tk.Tk()
        root.title("physical click")
        tk.Button(root, text="Click me", width=20, command=lambda: click(body)).pack(
            padx=40, pady=30
        )
        root.mainloop()


def run_offline(path):
    engine, body = make_engine()
    for t in (0.05, 0.35, 0.65):
        click(body, at=t)
    audio = engine.process(48000)
    synth.write_audio(path, audio, 48000)
    print(f"{path}: 3 clicks, peak {abs(audio).max():.3f} of full scale")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--offline", metavar="OUT.wav", help="no window, no device: write the clicks"
    )
    args = parser.parse_args()
    run_offline(args.offline) if args.offline else run_window()
