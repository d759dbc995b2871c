"""The PortAudio output stream of a live engine: opened with the compiled callback (or the
Python fallback), closed within a bounded time even when the audio server is gone."""

from __future__ import annotations

import threading

import numpy as np

from synth.errors import SynthError
from synth.live import native


def check_device(sd, device, channels: int, samplerate: int) -> dict:
    """PortAudio's output ``device`` (None: default), checked for ``channels`` float32
    channels at ``samplerate`` Hz (else SynthError)."""
    try:
        info = sd.query_devices(device, kind="output")
    except (ValueError, sd.PortAudioError) as exc:
        raise SynthError(
            f"no audio output device{'' if device is None else f' {device!r}'} "
            f"({exc}); list the devices with `python -m sounddevice`, or render offline "
            f"with Engine.process()"
        ) from None
    try:
        sd.check_output_settings(
            device=device, channels=channels, dtype="float32", samplerate=samplerate
        )
    except (ValueError, sd.PortAudioError) as exc:
        raise SynthError(
            f"the output device {info['name']!r} does not take {samplerate} Hz with "
            f"{channels} channel(s) ({exc}); its default rate is "
            f"{info['default_samplerate']:g} Hz: make the Engine at a rate it offers"
        ) from None
    return info


def open_stream(sd, state, callback: str, **settings):
    """A PortAudio float32 output stream mixing ``state``: the compiled callback on its
    address, or the Python fallback (``callback="python"``)."""
    if callback == "python":
        return sd.OutputStream(callback=python_callback(state.ctl), dtype="float32", **settings)
    import cffi

    ffi = cffi.FFI()
    return sd._StreamBase(
        kind="output", wrap_callback=None, dtype="float32",
        callback=ffi.cast("void *", native.stream_callback().address),
        userdata=ffi.cast("void *", state.address), **settings,
    )  # fmt: skip


#: Seconds the finaliser of a collected running engine waits for its stream to close.
CLOSE_TIMEOUT = 2.0
#: Streams whose server did not answer and their arrays, kept (freeing could crash them).
ABANDONED: list = []


def close_stream(stream, state, timeout: float, abort: bool = True) -> bool:
    """Stop (or abort) and close ``stream`` on a helper thread within ``timeout`` s (PortAudio
    can hang when the server is gone), else keep it for good. Returns whether it closed."""

    def close():
        try:
            stream.abort() if abort else stream.stop()
        finally:
            stream.close()

    worker = threading.Thread(target=close, name="synth-close-stream", daemon=True)
    worker.start()
    worker.join(timeout)
    if worker.is_alive():
        ABANDONED.append((stream, state))
        return False
    return True


def python_callback(ctl):
    """The fallback callback: Python (holding the arrays, not the engine) that runs the
    compiled block."""
    time_info = np.zeros(3)  # adc, current and dac time, s

    def callback(outdata, frames, info, status):
        time_info[1] = info.currentTime
        time_info[2] = info.outputBufferDacTime
        native.mix_engine(ctl, outdata, status._flags, time_info)

    return callback
