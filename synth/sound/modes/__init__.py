"""Old name of :mod:`synth.physics.modes` (the plate's modes are mechanics), kept for existing
imports: it and its submodules (``synth.sound.modes.ritz``, ...) are the same modules."""

import sys

from synth.physics import modes
from synth.physics.modes import basis, cache, closed_form, common, crossover, ritz

for submodule in (basis, cache, closed_form, common, crossover, ritz):
    sys.modules[f"{__name__}.{submodule.__name__.rsplit('.', 1)[1]}"] = submodule
sys.modules[__name__] = modes
