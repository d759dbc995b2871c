"""What the engine keeps on disk, below the physics and the sound: atomic files, the
bounded cache, audio files and levels, reproducible bytes (it imports only
:mod:`synth.checks` and :mod:`synth.errors`)."""
