"""Old name of :mod:`synth.store.audio`, kept for existing imports: the same module."""

import sys

from synth.store import audio

sys.modules[__name__] = audio
