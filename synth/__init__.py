"""Physically based synthesis of bouncing and impact sounds.

A ball is dropped on a plate; every impact is computed from the materials and sizes
(Hertz contact against the plate's mechanical impedance, with gravity), strung together by
a bounce scheduler, and heard through a modal model of the finite plate. SI units.

Every public name is imported on first use (PEP 562): ``import synth`` loads no numerical
library, and a render loads neither the analysis, the live engine nor the sound banks.
"""

from synth import jitcache  # noqa: F401  (first: picks numba's cache folder before numba loads)
from synth.errors import ParameterError, SynthError  # noqa: F401  (in __all__)

#: Where each public name lives: imported from there on first use.
_LAZY = {
    "Analysis": "synth.analysis",
    "AnalysisOptions": "synth.analysis",
    "Tick": "synth.analysis",
    "analyze": "synth.analysis",
    "analyze_file": "synth.analysis",
    "read_audio": "synth.store.audio",
    "write_audio": "synth.store.audio",
    "play": "synth.io.playback",
    "load_preset": "synth.io.presets",
    "render_preset": "synth.io.presets",
    "Body": "synth.live",
    "Engine": "synth.live",
    "EngineStats": "synth.live",
    "Voice": "synth.live",
    "BounceSequence": "synth.physics.bounces",
    "Impact": "synth.physics.bounces",
    "simulate_bounces": "synth.physics.bounces",
    "simulate_scene": "synth.physics.bounces",
    "ImpactResult": "synth.physics.contact",
    "solve_contact": "synth.physics.contact",
    "solve_impact": "synth.physics.contact",
    "LossFactor": "synth.physics.materials",
    "Material": "synth.physics.materials",
    "Rayleigh": "synth.physics.materials",
    "Accelerometer": "synth.physics.scene",
    "Ball": "synth.physics.scene",
    "Contact": "synth.physics.scene",
    "HollowBall": "synth.physics.scene",
    "Microphone": "synth.physics.scene",
    "Plate": "synth.physics.scene",
    "Scene": "synth.physics.scene",
    "Render": "synth.sound.render",
    "RenderInfo": "synth.sound.result",
    "RenderOptions": "synth.sound.options",
    "render": "synth.sound.render",
}
#: Public submodules, imported on first use; ``plate`` is the plate's modes under its
#: public name.
_SUBMODULES = {
    "contact": "synth.physics.contact",
    "materials": "synth.physics.materials",
    "plate": "synth.physics.modes",
    "bank": "synth.bank",
}

#: ``from synth import *`` takes every public name but the sound banks (imported by name).
__all__ = sorted(["ParameterError", "SynthError", *_LAZY, *(_SUBMODULES.keys() - {"bank"})])
__version__ = "0.4.0"


def __getattr__(name):
    """The public name ``name``, imported from its module on first use (PEP 562)."""
    import importlib

    if name in _SUBMODULES:
        value = importlib.import_module(_SUBMODULES[name])
    elif name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
    else:
        raise AttributeError(f"module 'synth' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__) | set(_SUBMODULES))
