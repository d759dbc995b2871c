"""numba's disk cache keyed on the whole package (synth.jitcache.stamp_with_the_package): a
kernel whose callee in another file changed is compiled again, not served stale."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numba

import synth
from synth import jitcache

CALLEE = "from synth.compilation import compiled\n\n\n@compiled()\ndef value():\n    return {}\n"
CALLER = (
    "from synth.compilation import compiled\nfrom synth.probe_callee import value\n\n\n"
    "@compiled()\ndef twice():\n    return 2.0 * value()\n"
)


def _run_caller(package_parent: Path, cache: Path) -> str:
    # -S: no .pth files, so no editable install's finder takes "synth" from elsewhere; the
    # copy first on the path, then the folder numba and numpy are installed in
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    env.pop("PYTHONPATH", None)
    paths = [str(package_parent), str(Path(numba.__file__).parent.parent)]
    code = f"import sys; sys.path[:0] = {paths!r}; from synth.probe_caller import twice; "
    code += "print(twice())"
    done = subprocess.run(
        [sys.executable, "-S", "-c", code], env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_a_changed_callee_in_another_file_recompiles_its_caller(tmp_path):
    # numba alone keys the caller's cache entry on the caller's file, whose bytes do not
    # change: it would print 2.0 again from the cached code that inlined the old callee.
    package = tmp_path / "site" / "synth"
    shutil.copytree(
        Path(synth.__file__).parent, package, ignore=shutil.ignore_patterns("__pycache__")
    )
    (package / "probe_caller.py").write_text(CALLER)
    (package / "probe_callee.py").write_text(CALLEE.format("1.0"))
    cache = tmp_path / "numba-cache"
    assert _run_caller(package.parent, cache) == "2.0"
    (package / "probe_callee.py").write_text(CALLEE.format("5.0"))
    assert _run_caller(package.parent, cache) == "10.0"


def test_package_digest_follows_every_source_file(tmp_path):
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    first = jitcache.package_digest(tmp_path)
    assert jitcache.package_digest(tmp_path) == first
    (tmp_path / "sub" / "b.py").write_text("y = 3\n")
    assert jitcache.package_digest(tmp_path) != first
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    assert jitcache.package_digest(tmp_path) == first
    (tmp_path / "sub" / "b.py").rename(tmp_path / "sub" / "c.py")
    assert jitcache.package_digest(tmp_path) != first


def test_the_package_kernels_carry_the_package_stamp():
    from synth.physics.modal_contact.kernels import ring_free

    stamp = ring_free._cache._cache_file._source_stamp
    assert stamp == ("synth package", jitcache.package_digest())
