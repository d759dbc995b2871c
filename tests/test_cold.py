"""First use: a light `import synth`, one compile per kernel, the note before a cold compile,
`synth warmup` and `synth bench cold`.

The cold cases run in subprocesses with their own empty NUMBA_CACHE_DIR (numba's disk
cache) so that the developer's warm cache is neither used nor touched.
"""

from __future__ import annotations

import cold_children as cold
import numba
import pytest

NOTE = "synth: compiling "


_python = cold.python_child


def test_import_synth_loads_no_numerical_library_and_every_name_resolves():
    code = (
        "import sys, synth\n"
        "heavy = sorted(m for m in ('numpy', 'numba', 'scipy', 'synth.analysis', 'synth.live')"
        " if m in sys.modules)\n"
        "print(heavy)\n"
        "names = [n for n in synth.__all__ if getattr(synth, n, None) is None]\n"
        "print(names, set(synth.__all__) <= set(dir(synth)))\n"
        "print(synth.plate.__name__, synth.contact.__name__, synth.materials.__name__)\n"
    )
    proc = _python(code)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "[]"
    assert lines[1] == "[] True"
    assert lines[2] == "synth.physics.modes synth.physics.contact synth.physics.materials"


def test_importing_the_live_engine_compiles_nothing(tmp_path):
    # numba compiles a cfunc where it is made: the PortAudio callback is made on first
    # use, so that the engine's note comes before its compile, not at an import
    code = (
        "import synth.live.engine\n"
        "from synth.live import native\n"
        "print(native.stream_callback.cache_info().currsize, len(native._run_block.overloads),"
        " native.rolling_block_code.cache_info().currsize)\n"
    )
    proc = _python(code, {"NUMBA_CACHE_DIR": str(tmp_path / "numba")})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["0", "0", "0"]
    assert NOTE not in proc.stderr


def test_unknown_attribute_is_an_attribute_error():
    import synth

    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        synth.nonexistent  # noqa: B018


def test_a_render_imports_neither_the_analysis_nor_the_live_engine_nor_the_banks(tmp_path):
    # nor what a scene on the plate's impedance does not use: scipy.special (the modes'
    # normalisation took two log-factorials from it) and the plate-coupled contact. The
    # command line reads the analysis options' declaration (synth.analysis.options, for the
    # flags of synth analyze) and nothing else of the analysis, and the banks' options'
    # declaration (synth.bank.options, for the flags of synth bank) and nothing else of the
    # banks. The plate's modes come from the cache, as for every render after a scene's
    # first: a fresh mode solve takes its Gauss-Legendre nodes from scipy.special (a first
    # render fills a private cache)
    cache = {"SYNTH_CACHE_DIR": str(tmp_path / "cache")}
    out = str(tmp_path / "x.wav")
    render = f"from synth.cli import main\nmain(['render', 'default', '-o', {out!r}])\n"
    assert _python(render, cache).returncode == 0
    code = (
        "import sys\n"
        + render
        + "analysis = [m for m in sys.modules if m.startswith('synth.analysis.')]\n"
        "print(analysis == ['synth.analysis.options'] or analysis)\n"
        "bank = [m for m in sys.modules if m.startswith('synth.bank.')]\n"
        "print(bank == ['synth.bank.options'] or bank)\n"
        "print(sorted(m for m in ('synth.live', 'sounddevice',"
        " 'matplotlib', 'scipy.special', 'synth.physics.modal_contact') if m in sys.modules))\n"
    )
    proc = _python(code, cache)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-3:] == ["True", "True", "[]"]


@pytest.fixture(scope="module")
def cold_children(tmp_path_factory):
    """The cold children (tests/cold_children.py), run once for the module: started at the
    run's start beside the tests when the run reaches this fixture, else here."""
    return cold.cold_children(tmp_path_factory.mktemp("cold"))


@pytest.mark.slow
def test_every_kernel_of_a_render_and_a_contact_compiles_once(cold_children):
    # A constant argument (or a counter started at a constant) reaches a compiled callee
    # typed as a literal, and numba compiles the callee once more for it: event_root was
    # compiled three times per integrator, solve and both integrators twice, _in_contact
    # twice. On an empty cache, every kernel of the package compiles one specialisation
    # (the clean child renders the default preset and solves the contacts after its
    # rolling render).
    counts = cold_children.clean["compiles"]
    assert counts["synth.physics.contact_kernels.dense.event_root"] >= 1
    assert counts["synth.sound.modal_bank.transform_kernels._in_contact"] >= 1
    assert counts["synth.physics.contact_kernels.radau.integrate_radau"] >= 1
    assert {k: n for k, n in counts.items() if n != 1} == {}


@pytest.mark.slow
def test_every_kernel_of_a_rolling_render_compiles_once(cold_children):
    # The rolling preset on an empty cache: the envelope's spline was evaluated by the
    # dilation on a writable array of coefficients and by the rolling contact on the
    # envelope's read-only one, two types to numba, so envelope_at compiled twice.
    counts = cold_children.clean["compiles"]
    assert counts["synth.physics.surface.envelope_at"] >= 1
    assert counts["synth.physics.rolling_kernels.roll"] >= 1
    assert {k: n for k, n in counts.items() if n != 1} == {}


@pytest.mark.slow
def test_a_render_does_not_depend_on_what_compiled_before_it(cold_children):
    # The same rolling preset in two new processes on empty numba caches, one of which
    # first compiles other kernels from Python (the live engine's block, the contact law
    # alone, a rolling): the same bytes. numba compiles a kernel, and its own helpers, with
    # the fast-math flags of the first kernel that calls it; with kernels on different
    # flags, whichever family compiled first set the bits of every later render.
    # A third process renders on the first one's cache: the kernels loaded from numba's
    # disk cache give the bytes of the kernels compiled in the run (with fast-math
    # contraction they did not).
    runs = (cold_children.clean, cold_children.others_first, cold_children.again)
    assert runs[0]["rolling"] == runs[1]["rolling"] == runs[2]["rolling"]
    assert cold_children.again["compiles"] == {}  # loaded from the disk cache


@pytest.mark.slow
def test_the_compiled_callback_has_no_python_and_no_allocation(cold_children):
    # the audio thread's code as compiled (fresh, in a child with an empty numba cache, as
    # cached code cannot be inspected), callees included: no call into Python's C API (no
    # GIL) and none into numba's allocator (its arrays are views made from addresses)
    found = dict(cold_children.others_first["callback"])
    assert found.pop("_write_block")  # the callees' code is in the inspected IR
    # the voices' code too: slots rung, faded and freed, voice-ended events (the helpers
    # that take and steal slots are inlined into mix_body), and the master bus' limiter
    for callee in ("mix_body", "_advance", "_add_slot", "_settle", "limit_block"):
        assert found.pop(callee), callee
    assert found.pop("clock_gettime")  # its cost is timed from its entry
    # and not the rolling voices' code: compiled apart, called through its address by an
    # engine with rolling slots only
    assert set(found.values()) == {False}, found
    # that block: the rolling voices' (their contact integrated by the offline kernel's
    # loop), no Python, no allocation either
    rolling = dict(cold_children.others_first["rolling_block"])
    for callee in ("mix_rolls", "rolling_kernels4roll"):
        assert rolling.pop(callee), callee
    assert set(rolling.values()) == {False}, rolling
    # one specialisation of each live kernel: the pulses transformed from Python
    # (transform_pending, limit -1: all) and by the mixing (an int64 limit) took two of
    # transform_pulses, the longest kernel of the block, when the -1 was a literal
    assert cold_children.others_first["specialised_twice"] == []


def test_every_kernel_group_has_a_recorded_compile_time():
    # the first-use note of every group (the live rolling block's too, compiled when an
    # engine with max_rolls >= 1 starts) says how long it compiles: synth warmup --record
    # measured each (its steps run every group's kernels)
    from synth.compilation import GROUPS, recorded_seconds

    recorded = recorded_seconds()
    assert set(GROUPS) <= set(recorded)
    assert all(seconds > 0.0 for seconds in recorded.values())


def test_compile_log_records_a_compile_with_its_own_and_total_time():
    from synth.compilation import CompileLog

    @numba.njit
    def inner(x):
        return x + 1.0

    @numba.njit
    def outer(x):
        return inner(x) * 2.0

    log = CompileLog()
    with log.recording():
        assert outer(1.0) == 4.0
    names = [c.kernel.rsplit(".", 1)[-1] for c in log.compiles]
    assert names[-1] == "outer" and "inner" in names
    top = log.compiles[-1]
    assert top.depth == 0 and top.signature == "float64"
    # the outer compile's total holds the inner's; its own time does not
    nested = sum(c.own_seconds for c in log.compiles[:-1])
    assert top.total_seconds == pytest.approx(top.own_seconds + nested, rel=1e-9, abs=1e-12)
    assert log.seconds == pytest.approx(top.total_seconds, rel=1e-9, abs=1e-12)


def _doubled(x):
    return 2.0 * x


def test_compile_log_counts_the_compile_of_a_cfunc():
    # numba signals numba:compile for dispatchers only: the live engine's PortAudio
    # callback, a cfunc that compiles the whole mixing, was missing from the log (from
    # synth warmup and from the first-use note's estimate)
    import numba
    from numba import types

    from synth.compilation import CompileLog, cfunc_compiling

    signature = types.float64(types.float64)
    log = CompileLog()
    with log.recording(), cfunc_compiling(_doubled, signature):
        made = numba.cfunc(signature, nopython=True)(_doubled)
    assert made.ctypes(1.5) == 3.0
    assert [(c.kernel, c.signature, c.depth) for c in log.compiles] == [
        (f"{__name__}._doubled", "float64", 0)
    ]
    assert log.compiles[0].own_seconds > 0.0


@pytest.mark.slow
def test_warmup_compiles_and_says_so_once_then_nothing_on_a_warm_cache(cold_children):
    # Step 2 (a contact by Radau IIA) on an empty numba cache: the note on stderr once,
    # before compiling, and the kernels listed with their times; the same again on the
    # cache it filled: no note, nothing compiled.
    cold = cold_children.warmup
    assert cold.returncode == 0, cold.stderr
    notes = [line for line in cold.stderr.splitlines() if line.startswith(NOTE)]
    assert len(notes) == 1
    assert notes[0].startswith(
        "synth: compiling the stiff contact kernels (Radau IIA) for first use"
    )
    assert notes[0].endswith("; later runs start at once")
    assert "synth.physics.contact_kernels.radau.integrate_radau" in cold.stdout
    assert "synth.physics.contact_kernels.dop853" not in cold.stdout  # not used, not compiled
    warm = cold_children.warmup_again
    assert warm.returncode == 0, warm.stderr
    assert NOTE not in warm.stderr
    assert "0 compiles" in warm.stdout and "(all kernels already compiled)" in warm.stdout
    assert "total: 0 compiles" in warm.stdout


def test_bench_cold_measures_the_import_in_child_processes():
    from benchmarks import cold

    rows = cold.run_cold(("import",))
    assert [(r["case"], r["cold"], r["status"], r["noted"]) for r in rows] == [
        ("import", True, 0, False),
        ("import", False, 0, False),
    ]
    for r in rows:
        assert r["cpu_s"] > 0.0 and r["wall_s"] > 0.0
        # the child's own high-water mark, not the forking parent's (this process holds
        # numba and numpy, far more than a bare import synth)
        assert 0.0 < r["peak_mb"] < 60.0
    text = cold.format_cold(rows)
    assert "| `import synth` | empty |" in text and "| `import synth` | warm |" in text
    assert "- `import synth`, empty caches:" in text and "target under 0.5 s" in text


def test_the_live_block_is_compiled_into_the_callback_only():
    # numba links a compiled callee into each caller and compiles it to machine code again
    # there: the callback, the block and the mixing, three compiled entries to the same
    # tree of kernels, compiled it three times over. The levels between the callback and
    # the bodies' mixing are inlined into the callback, which Python calls as well: none
    # of them has a specialisation of its own (compiled, or loaded from the disk cache).
    # Last in the module: with the slow tests, the cold children's fixture has filled
    # the suite's own numba cache with this code (SUITE_CACHE_WARMUP), loaded here.
    from synth.live import native

    native.warm_up()
    for inlined in (native._run_block, native._mix_engine, native._mix_one_body):
        assert inlined.overloads == {}, inlined.py_func.__name__
