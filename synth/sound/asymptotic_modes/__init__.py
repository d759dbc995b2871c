"""Old name of :mod:`synth.physics.asymptotic_modes`, kept for existing imports: it and its
submodules (``synth.sound.asymptotic_modes.roots``, ...) are the same modules."""

import sys

from synth.physics import asymptotic_modes
from synth.physics.asymptotic_modes import factors, ritz, roots

for submodule in (factors, ritz, roots):
    sys.modules[f"{__name__}.{submodule.__name__.rsplit('.', 1)[1]}"] = submodule
sys.modules[__name__] = asymptotic_modes
