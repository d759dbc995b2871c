"""Shared test helpers."""

import numpy as np
import pytest


def _damage(path, how, array=None):
    """Damage the cache file ``path`` (``.npz``) in one of the ways a reader must survive:
    ``garbage`` (not an npz file), ``truncate`` (half of it), ``wrong-key`` (another key
    stored), ``wrong-shape`` (``array`` one element short) or ``nan`` (``array`` NaN)."""
    data = path.read_bytes()
    if how == "garbage":
        path.write_bytes(b"not an npz file")
        return
    if how == "truncate":
        path.write_bytes(data[: len(data) // 2])
        return
    with np.load(path) as z:
        arrays = dict(z)
    if how == "wrong-key":
        arrays["key"] = np.array("something else")
    elif how == "wrong-shape":
        arrays[array] = arrays[array][:-1]
    elif how == "nan":
        arrays[array] = np.full_like(arrays[array], np.nan)
    else:
        raise ValueError(f"unknown damage {how!r}")
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


@pytest.fixture
def damage_cache_file():
    """A function ``damage(path, how, array=None)`` that damages a cache file."""
    return _damage


@pytest.fixture
def empty_caches(tmp_path, monkeypatch):
    """A private, empty disk cache and empty memory caches of plate modes and radiation
    gains (a render then starts from a fresh mode solve)."""
    from synth.sound import modes, radiation

    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache"))
    modes.clear_memory_cache()
    radiation.clear_memory_cache()
    yield
    modes.clear_memory_cache()
    radiation.clear_memory_cache()
