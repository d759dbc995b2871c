"""A JACK server on its dummy backend: a clocked audio server that needs no sound card.

``jackd -d dummy -r RATE -p FRAMES`` runs the JACK graph on a timer, and PortAudio's JACK
host API sees it as an output device, so the live engine's stream runs for real (the
callback is driven by the server's clock, underflows are reported) on a machine without
audio hardware: the tests and ``synth bench live`` use it. Needs the ``jackd`` program
(Debian/Ubuntu: ``apt-get install jackd2``) and PortAudio built with JACK support
(Debian's ``libportaudio2`` is).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import threading
import time

from synth.errors import SynthError

#: JACK's registry holds this many servers (JACK_MAX_SERVERS in JACK2's shm.c).
MAX_SERVERS = 8
#: The names the servers take, tried in turn: JACK reclaims the registry entry of a
#: server that died without unregistering (killed) only when a server of the same name
#: starts, so a fixed set of names keeps such entries from filling the registry.
SERVER_NAMES = tuple(f"synth-dummy-{i}" for i in range(MAX_SERVERS))

#: Seconds to wait for the server to come up (or to go away).
STARTUP_TIMEOUT = 15.0
#: What jackd's timed driver (the dummy backend's) prints when one of its own cycles ended
#: after the next one was due (JACK2's JackTimedDriver::ProcessWait): the server's own
#: thread ran late, so every client's output of that cycle is flagged, whatever its work.
DRIVER_LATE = "JackTimedDriver::Process XRun"


def _bounded(call, timeout: float) -> bool:
    """Run ``call()`` on a helper thread; whether it returned within ``timeout`` s."""
    worker = threading.Thread(target=call, daemon=True)
    worker.start()
    worker.join(timeout)
    return not worker.is_alive()


def _server_answers(name: str) -> bool:
    """Whether a live JACK server runs under ``name`` (``jack_lsp`` connects to it)."""
    env = dict(os.environ, JACK_NO_START_SERVER="1")
    try:
        out = subprocess.run(
            ["jack_lsp", "-s", name], capture_output=True, timeout=10, env=env, check=False
        )
    except (OSError, subprocess.TimeoutExpired):
        return False
    return out.returncode == 0


def jackd_available() -> bool:
    """Whether the ``jackd`` program is on the PATH."""
    return shutil.which("jackd") is not None


def _reinitialize(sd) -> None:
    """Make PortAudio list the host APIs again (it scans them once, when initialised):
    sounddevice's documented way to refresh its device list."""
    sd._terminate()
    sd._initialize()


def jack_output_device(sd) -> int | None:
    """Index of the JACK host API's default output device, or None."""
    for api in sd.query_hostapis():
        if "JACK" in api["name"] and api["default_output_device"] >= 0:
            return int(api["default_output_device"])
    return None


class JackDummyServer:
    """A private ``jackd`` on the dummy backend at ``samplerate`` Hz and ``period`` frames.

    Use as a context manager: it starts the server under the first free name of
    :data:`SERVER_NAMES` (so that it never meets another JACK server on the machine),
    points PortAudio's JACK client at it (``JACK_DEFAULT_SERVER``), and yields itself with
    ``device``, the PortAudio output device index. On exit it stops the server and lets
    PortAudio rescan.
    """

    def __init__(self, samplerate: int = 48000, period: int = 256):
        self.samplerate = int(samplerate)
        self.period = int(period)
        self.name = SERVER_NAMES[0]
        self.device: int | None = None
        self._process: subprocess.Popen | None = None
        self._log = None
        self.realtime = False
        self._saved_env: dict = {}

    def _set_env(self, key, value):
        self._saved_env.setdefault(key, os.environ.get(key))
        os.environ[key] = value

    def start(self) -> JackDummyServer:
        """Start the server, with realtime scheduling when the system allows it (without
        it, on a busy machine, the server's period can come late and the clients' output
        runs dry), else without."""
        errors = []
        for name in SERVER_NAMES:
            if _server_answers(name):  # in use by a live server: the next name
                continue
            self.name = name
            for realtime in (True, False):
                try:
                    return self._start(realtime=realtime)
                except SynthError as exc:
                    errors.append(str(exc))
        raise SynthError(f"no JACK dummy server could start: {errors[-1]}")

    def _start(self, realtime: bool) -> JackDummyServer:
        if not jackd_available():
            raise SynthError(
                "the JACK server is not installed (Debian/Ubuntu: apt-get install jackd2)"
            )
        from synth.io.playback import sounddevice_module

        sd = sounddevice_module()
        # no D-Bus device reservation (there is no session bus in a container)
        self._set_env("JACK_NO_AUDIO_RESERVATION", "1")
        self._set_env("JACK_DEFAULT_SERVER", self.name)
        self._set_env("JACK_NO_START_SERVER", "1")
        self._log = tempfile.TemporaryFile(mode="w+")
        self._process = subprocess.Popen(
            [
                "jackd",
                "-n",
                self.name,
                "--realtime" if realtime else "--no-realtime",
                "-d",
                "dummy",
                "-r",
                str(self.samplerate),
                "-p",
                str(self.period),
            ],
            stdout=self._log,
            stderr=subprocess.STDOUT,
            text=True,
        )
        deadline = time.monotonic() + STARTUP_TIMEOUT
        while time.monotonic() < deadline:
            status = self._process.poll()
            if status is not None:
                self._log.seek(0)
                err = self._log.read()
                self._process = None
                self.stop()
                raise SynthError(f"jackd exited with status {status}: {err.strip()[-500:]}")
            _reinitialize(sd)
            self.device = jack_output_device(sd)
            if self.device is not None:
                self.realtime = realtime
                return self
            time.sleep(0.2)
        self.stop()
        raise SynthError(f"the JACK dummy server did not come up within {STARTUP_TIMEOUT} s")

    def log(self) -> str:
        """What the server has printed so far (read without moving its write offset)."""
        if self._log is None:
            return ""
        fd = self._log.fileno()
        return os.pread(fd, os.fstat(fd).st_size, 0).decode(errors="replace")

    def late_cycles(self) -> int:
        """The server's own cycles that ended late so far (:data:`DRIVER_LATE` lines)."""
        return self.log().count(DRIVER_LATE)

    @property
    def pid(self) -> int | None:
        """The server's process id while it runs, else None."""
        return self._process.pid if self.alive else None

    @property
    def alive(self) -> bool:
        return self._process is not None and self._process.poll() is None

    def ports(self) -> list[str]:
        """The server's ports (``jack_lsp``), e.g. to check that a client has left."""
        out = subprocess.run(
            ["jack_lsp", "-s", self.name],
            capture_output=True,
            text=True,
            timeout=10,
            env=os.environ.copy(),
        )
        return [line.strip() for line in out.stdout.splitlines() if line.strip()]

    def _restore_env(self):
        for key, value in self._saved_env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        self._saved_env = {}

    def stop(self) -> None:
        # PortAudio's JACK host API must let go of the server before it goes away
        try:
            from synth.io.playback import sounddevice_module

            sd = sounddevice_module()
        except SynthError:
            sd = None
        if sd is not None and not _bounded(sd._terminate, STARTUP_TIMEOUT):
            sd = None  # PortAudio waits on a stream it cannot close: leave it be
        if self._process is not None and self._process.poll() is None:
            self._process.terminate()
            try:
                self._process.wait(timeout=STARTUP_TIMEOUT)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        self._process = None
        if self._log is not None:
            self._log.close()
            self._log = None
        self._restore_env()
        if sd is not None:
            sd._initialize()

    def __enter__(self) -> JackDummyServer:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
