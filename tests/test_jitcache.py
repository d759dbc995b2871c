"""numba's disk cache keyed on each kernel's import closure
(synth.jitcache.stamp_with_the_import_closure): a kernel whose callee in another file
changed, directly or through a module it imports, is compiled again, never served stale;
an edit of a module it does not import keeps its cache."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numba

import synth
from synth import jitcache

CONSTANT = "VALUE = {}\n"
CALLEE = (
    "from synth.compilation import compiled\nfrom synth.probe_constant import VALUE\n\n\n"
    "@compiled()\ndef value():\n    return VALUE\n"
)
CALLER = (
    "from synth.compilation import compiled\nfrom synth.probe_callee import value\n\n\n"
    "@compiled()\ndef twice():\n    return 2.0 * value()\n"
)


def _run_caller(package_parent: Path, cache: Path) -> tuple[str, int]:
    """``twice()`` in a new Python on the copy of the package: its value, and how many
    times it was loaded from numba's disk cache (0: compiled)."""
    # -S: no .pth files, so no editable install's finder takes "synth" from elsewhere; the
    # copy first on the path, then the folder numba and numpy are installed in
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    env.pop("PYTHONPATH", None)
    paths = [str(package_parent), str(Path(numba.__file__).parent.parent)]
    code = f"import sys; sys.path[:0] = {paths!r}; from synth.probe_caller import twice; "
    code += "print(twice(), sum(twice.stats.cache_hits.values()))"
    done = subprocess.run(
        [sys.executable, "-S", "-c", code], env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    value, hits = done.stdout.split()
    return value, int(hits)


def test_a_kernel_recompiles_after_an_edit_of_its_imports_only(tmp_path):
    # numba alone keys the caller's cache entry on the caller's file, whose bytes do not
    # change: it would print 2.0 again from the cached code that inlined the old constant.
    package = tmp_path / "site" / "synth"
    shutil.copytree(
        Path(synth.__file__).parent, package, ignore=shutil.ignore_patterns("__pycache__")
    )
    (package / "probe_caller.py").write_text(CALLER)
    (package / "probe_callee.py").write_text(CALLEE)
    (package / "probe_constant.py").write_text(CONSTANT.format("1.0"))
    cache = tmp_path / "numba-cache"
    assert _run_caller(package.parent, cache) == ("2.0", 0)
    # a module outside the caller's import closure: the cached kernel is loaded
    with open(package / "dsp.py", "a") as dsp:
        dsp.write("\n# an edit\n")
    assert _run_caller(package.parent, cache) == ("2.0", 1)
    # a module the callee imports (the closure's second step): compiled again
    (package / "probe_constant.py").write_text(CONSTANT.format("5.0"))
    assert _run_caller(package.parent, cache) == ("10.0", 0)


def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)


def test_the_import_closure_follows_every_form_of_import(tmp_path):
    root = tmp_path / "pkg"
    _write(
        root,
        {
            "__init__.py": "from pkg.lazy import thing\n",
            "kernel.py": (
                "import os\nfrom pkg import near  # a submodule\n"
                "from .sub import (\n    deep,  # relative, over two lines\n)\n"
                "def f():\n    import pkg.late as late\n    return late\n"
            ),
            "near.py": "from pkg.sub.deep import X\n",
            "late.py": "",
            "sub/__init__.py": "",
            "sub/deep.py": "X = 1\n",
            "lazy/__init__.py": "def __getattr__(name):\n    return name\n",
            "lazy/inner.py": "",
            "uses_lazy.py": "from pkg.lazy import thing\n",
            "other.py": "import pkg.kernel\n",
        },
    )
    closure = {
        p.relative_to(root).as_posix() for p in jitcache.import_closure(root / "kernel.py", root)
    }
    assert closure == {"kernel.py", "near.py", "late.py", "sub/deep.py"}
    # a package that imports its names on first use (PEP 562) brings all its modules
    lazy = {
        p.relative_to(root).as_posix() for p in jitcache.import_closure(root / "uses_lazy.py", root)
    }
    assert lazy == {"uses_lazy.py", "lazy/__init__.py", "lazy/inner.py"}
    first = jitcache.closure_digest(root / "kernel.py", root)
    (root / "other.py").write_text("import pkg.kernel  # edited\n")
    assert jitcache.closure_digest(root / "kernel.py", root) == first
    (root / "sub" / "deep.py").write_text("X = 2\n")
    assert jitcache.closure_digest(root / "kernel.py", root) != first


def test_the_package_kernels_carry_their_import_closure_stamp():
    from synth.physics.modal_contact import kernels

    stamp = kernels.ring_free._cache._cache_file._source_stamp
    assert stamp == ("synth import closure", jitcache.closure_digest(Path(kernels.__file__)))
    closure = {p.name for p in jitcache.import_closure(Path(kernels.__file__))}
    assert "engine.py" not in closure and "equations.py" in closure


def test_a_kernel_another_process_compiles_is_waited_for_then_loaded(tmp_path, monkeypatch):
    import fcntl
    import threading

    import numba

    from synth import compilation
    from synth.vecmath import halvings_for

    # a dispatcher of the package's kernel with no specialisation yet, on its cache entry
    kernel = numba.njit(cache=True)(halvings_for.py_func)
    monkeypatch.setenv(compilation.KERNEL_LOCKS, str(tmp_path))
    path = compilation.kernel_lock_file(tmp_path, kernel)
    assert path == compilation.kernel_lock_file(tmp_path, halvings_for)  # one cache entry
    path.parent.mkdir()
    holder = open(path, "wb")
    fcntl.flock(holder, fcntl.LOCK_EX)  # as a process compiling it
    try:
        caller = threading.Thread(target=kernel, args=(3.0,))
        caller.start()
        caller.join(0.2)
        assert caller.is_alive() and not kernel.overloads  # it waits for the lock
    finally:
        holder.close()
    caller.join(60)
    assert not caller.is_alive() and len(kernel.overloads) == 1
    assert kernel(3.0) == 2


def test_a_group_compiled_ahead_is_waited_for_in_the_same_cache_only(tmp_path, monkeypatch):
    import fcntl
    import threading

    from synth import compilation

    monkeypatch.setenv(compilation.LOCKS, str(tmp_path))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    compilation.same_cache_file(tmp_path).write_text(str(tmp_path / "numba"))
    holder = open(compilation.lock_file(tmp_path, "live"), "wb")
    fcntl.flock(holder, fcntl.LOCK_EX)
    waiter = threading.Thread(target=compilation.wait_for_ahead, args=("live",))
    waiter.start()
    waiter.join(0.2)
    assert waiter.is_alive()  # the group's lock is held: it waits
    compilation.wait_for_ahead("contact")  # no lock file: this group is not compiled ahead
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "other"))
    compilation.wait_for_ahead("live")  # another cache: nothing to wait for
    holder.close()
    waiter.join(60)
    assert not waiter.is_alive()


def test_a_kernel_runs_when_its_cache_entry_cannot_be_written(tmp_path):
    # Under a file size limit of 1 kB (ulimit -f) numba's cache file of a compiled kernel
    # cannot be written: numba would raise EFBIG out of the call; the kernel runs from memory
    # (exp(0.5) to float rounding) and one note says why it is not kept; no file is left.
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (1024, resource.RLIM_INFINITY))

    cache = tmp_path / "numba-cache"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    code = "from synth.vecmath import exp_small; print(repr(exp_small(0.5)))"
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300,
        preexec_fn=limit,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert abs(float(done.stdout) - 1.6487212707001282) < 1e-15
    notes = done.stderr.splitlines()
    assert len(notes) == 1 and "numba's cache could not be written" in notes[0], notes
    assert not [p for p in cache.rglob("*") if p.is_file() and ".tmp." in p.name]
