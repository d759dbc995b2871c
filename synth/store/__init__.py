"""What the engine keeps on disk, below the physics and the sound: files written whole or
not at all (:mod:`~synth.store.atomic`), the size-bounded on-disk cache
(:mod:`~synth.store.cache`), audio files and their levels (:mod:`~synth.store.audio`) and
reproducible bytes (:mod:`~synth.store.reproducible`). It imports nothing above
:mod:`synth.checks` and :mod:`synth.errors`."""
