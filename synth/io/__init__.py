"""The front ends that touch files or devices: presets, plots and playback. The on-disk
cache, atomic writes, audio files and reproducible bytes live in :mod:`synth.store`; their
old names here (``synth.io.cache``, ...) are the same modules."""
