"""The cold children of tests/test_cold.py: processes on empty numba caches whose compiles and
renders those tests read. They cost a whole compile each (tens of seconds of CPU), so a run
that reads them starts them at its start, beside the tests. A run in one process starts them
on a thread of its own at a lower priority (:func:`start_early`): the test process keeps its
core and the children take what the other core leaves. A run over pytest-xdist workers starts
them on a thread of the controller (:func:`start_for_workers`), at the workers' priority
(they share both cores with two workers, and each child's time is bounded), and the
controller writes their results into a folder the worker that reads them waits on; the
workers take the files that read them last."""

from __future__ import annotations

import json
import os
import pickle
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

#: Niceness of children started beside the tests (the test process is the critical path).
BESIDE_NICENESS = 10
_started: Future | None = None
_folder: Path | None = None
#: Environment variable: the folder of the cold children of a run over pytest-xdist workers
#: (:func:`start_for_workers`), which the controller gives the workers before they start.
FOLDER = "SYNTH_TEST_COLD_CHILDREN"
#: In that folder: a worker's note that its tests read the children (:func:`mark_wanted`),
#: the controller's that it started them, and their results (pickled, written whole).
WANTED, STARTED, RESULTS = "wanted", "started", "results.pickle"


def python_child(code: str, env: dict | None = None, cwd=None, args=(), niceness: int = 0):
    """``code`` in a new Python with ``env`` added to this one's environment, ``niceness``
    added to its niceness; its completed process (within 900 s)."""
    with subprocess.Popen(
        [sys.executable, "-c", code, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, **(env or {})),
        cwd=cwd,
    ) as child:
        if niceness:
            os.setpriority(
                os.PRIO_PROCESS, child.pid, os.getpriority(os.PRIO_PROCESS, 0) + niceness
            )
        try:
            out, err = child.communicate(timeout=900)
        except subprocess.TimeoutExpired:
            child.kill()
            raise
    return subprocess.CompletedProcess(child.args, child.returncode, out, err)


#: A child on an empty numba cache renders the rolling preset (``clean``: nothing compiled
#: before, and then the default preset and a contact by each integrator, in one process so
#: that the kernels both renders use compile once; ``again``: on the cache a ``clean``
#: child filled; ``others-first``: other kernels compiled from Python first, the live
#: engine's callback and rolling block among them, whose fresh code it inspects: cached
#: code cannot be). It prints one JSON line: the rolling render's size and digest, the
#: compiles numba logged from the first render on, what the live engine's code calls.
COLD_CHILD = """
import hashlib, json, sys
from synth.compilation import CompileLog
case = sys.argv[1]
found = {}
log = CompileLog()
if case == "others-first":
    from synth.live import native
    from synth.physics import rolling, surface
    from synth.physics.contact_kernels import equations
    native.warm_up(rolling=True)
    symbols = (
        "PyGILState_Ensure", "PyEval_", "PyObject_", "NRT_MemInfo_alloc", "NRT_Allocate",
        "clock_gettime", "_write_block", "mix_body", "_advance", "_add_slot", "_settle",
        "limit_block", "mix_rolls", "rolling_kernels4roll",
    )
    for name, code in (("callback", native.stream_callback()),
                       ("rolling_block", native.rolling_block_code())):
        ir = code.inspect_llvm()
        found[name] = {symbol: symbol in ir for symbol in symbols}
    from synth.live import kernel
    found["specialised_twice"] = sorted(
        n for n, f in vars(kernel).items() if len(getattr(f, "overloads", ())) > 1
    )
    equations.force(1e-6, 0.1, 1e9, 1.5, 0.0, 0.0)
    from synth.physics.scene import Ball, Plate
    ball = Ball("steel", 0.01)
    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=1e-4, hurst=0.8)
    env = surface.contact_envelope(
        surface.rough_profile(spec, length=0.02, spacing=5e-6, seed=3), ball.radius
    )
    rolling.roll(
        ball, Plate("glass", 0.006, 0.5, 0.4), env, speed=0.2, duration=0.01,
        samplerate=48000, origin=(0.1, 0.2), start=0.005,
    )
with log.recording():
    import synth
    r = synth.render_preset("thesis-steel10-mdf18-rolling", normalize="none")
    found["rolling"] = [r.audio.size, hashlib.sha256(r.audio.tobytes()).hexdigest()]
    if case == "clean":
        from synth.physics.contact import solve_contact
        synth.render_preset("default")
        for method in ("auto", "Radau"):
            solve_contact(mass=4e-3, stiffness=1e9, admittance=1e-3, speed=1.0, method=method)
        solve_contact(mass=4e-3, stiffness=1e9, admittance=1e-3, speed=1.0, viscous_time=1e-7)
found["compiles"] = {k: n for k, n, _ in log.by_kernel() if k.startswith("synth.")}
print(json.dumps(found))
"""


#: ``synth warmup`` of step 2 (a contact by Radau IIA).
WARMUP = "from synth.cli import main; raise SystemExit(main(['warmup', '--step', '2']))"


#: The live engine's code (the audio callback and the rolling voices' block) compiled into
#: the suite's own numba cache, the one this process loads from, by a child beside the cold
#: ones: it is this process' longest compile, and a core is free while the children run.
SUITE_CACHE_WARMUP = "from synth.live import native; native.warm_up(rolling=True)"


@dataclass(frozen=True)
class ColdChildren:
    """What the children of :data:`COLD_CHILD` printed (one JSON object each), and the two
    runs of :data:`WARMUP`: on an empty numba cache, then on the cache it filled."""

    clean: dict
    others_first: dict
    again: dict
    warmup: subprocess.CompletedProcess
    warmup_again: subprocess.CompletedProcess


def _printed(done: subprocess.CompletedProcess) -> dict:
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.splitlines()[-1])


def run_cold_children(tmp: Path, niceness: int = 0) -> ColdChildren:
    """Run the children, two at a time (one single-threaded compile each), in this order,
    each on the next free core: the others-first child (it compiles the live engine too),
    the clean one then its ``again`` on its cache, the live engine into the suite's cache
    (:data:`SUITE_CACHE_WARMUP`), the two warmups on a cache of their own. Each child's
    numba and synth caches are ``tmp / NAME``, or the suite's own for the live engine's."""

    def child(cache, code, *args):
        env = {} if cache is None else {
            "NUMBA_CACHE_DIR": str(tmp / cache), "SYNTH_CACHE_DIR": str(tmp / cache),
        }  # fmt: skip
        return python_child(code, env, args=args, niceness=niceness)

    def chain(*children):  # one after the other (the later on the earlier's cache)
        return lambda: [child(*c) for c in children]

    with ThreadPoolExecutor(max_workers=2) as pool:
        others_first = pool.submit(chain(("b", COLD_CHILD, "others-first")))
        clean = pool.submit(chain(("a", COLD_CHILD, "clean"), ("a", COLD_CHILD, "again")))
        suite = pool.submit(chain((None, SUITE_CACHE_WARMUP)))
        warmups = pool.submit(chain(("d", WARMUP), ("d", WARMUP)))
    (suite_warmup,) = suite.result()
    assert suite_warmup.returncode == 0, suite_warmup.stderr[-2000:]
    clean_run, again = clean.result()
    warmup, warmup_again = warmups.result()
    return ColdChildren(
        _printed(clean_run),
        _printed(others_first.result()[0]),
        _printed(again),
        warmup,
        warmup_again,
    )


def start_early() -> None:
    """Start :func:`run_cold_children` on a thread of this process, in a temporary folder,
    at :data:`BESIDE_NICENESS`: the run's tests go on while the children compile."""
    global _started, _folder
    _folder = Path(tempfile.mkdtemp(prefix="synth-cold-"))
    _started = Future()

    def run():
        try:
            _started.set_result(run_cold_children(_folder, BESIDE_NICENESS))
        except BaseException as exc:  # handed to the tests that read the children
            _started.set_exception(exc)

    threading.Thread(target=run, name="cold-children", daemon=True).start()


def mark_wanted(folder: Path) -> None:
    """A worker's note in ``folder`` (:data:`FOLDER`) that its tests read the children."""
    (folder / WANTED).touch()


def start_for_workers(folder: Path) -> threading.Thread | None:
    """The controller of a run over workers: if a worker noted that its tests read the
    children (:func:`mark_wanted`), run :func:`run_cold_children` in ``folder`` on a thread
    of this process at its priority, from the start of the run, and write their
    results (or the error's traceback) into ``folder`` once all have ended; None if no test
    reads them."""
    if not (folder / WANTED).exists():
        return None
    (folder / STARTED).touch()

    def run():
        try:
            data = pickle.dumps(run_cold_children(folder))
        except BaseException:  # handed to the test that reads the children, which waits
            data = pickle.dumps(traceback.format_exc())
        part = folder / (RESULTS + ".part")
        part.write_bytes(data)
        os.replace(part, folder / RESULTS)

    thread = threading.Thread(target=run, name="cold-children", daemon=True)
    thread.start()
    return thread


def _results_of_controller(folder: Path) -> ColdChildren:
    """The children's results the controller writes into ``folder``, once written."""
    path = folder / RESULTS
    while not path.exists():
        time.sleep(0.2)
    outcome = pickle.loads(path.read_bytes())
    if isinstance(outcome, str):
        raise RuntimeError(f"the cold children failed:\n{outcome}")
    return outcome


def remove_folder() -> None:
    """Remove the folder of children started early, once they have ended."""
    if _folder is not None and _started.done():
        shutil.rmtree(_folder, ignore_errors=True)


def cold_children(tmp: Path) -> ColdChildren:
    """The children's results: those started early (by this process, or by the controller
    of this worker), else run now in ``tmp``."""
    if _started is not None:
        return _started.result()
    folder = os.environ.get(FOLDER)
    if folder and (Path(folder) / STARTED).exists():
        return _results_of_controller(Path(folder))
    return run_cold_children(tmp)
