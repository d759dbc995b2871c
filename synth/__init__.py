"""Physically based synthesis of bouncing and impact sounds, in SI units: Hertz contact against
the plate's impedance, a bounce scheduler and a modal model of the finite plate. Every public
name is imported on first use (PEP 562), so ``import synth`` loads no numerical library."""

from synth import jitcache  # noqa: F401  (first: picks numba's cache folder before numba loads)
from synth.errors import ParameterError, SynthError  # noqa: F401  (in __all__)

#: Where each public name lives: imported from there on first use.
_LAZY = {
    name: module
    for module, names in {
        "synth.analysis": "Analysis AnalysisOptions Tick analyze analyze_file",
        "synth.store.audio": "read_audio write_audio",
        "synth.io.playback": "play",
        "synth.io.presets": "load_preset render_preset",
        "synth.live": "Body Engine EngineStats Voice",
        "synth.physics.bounces": "BounceSequence Impact simulate_bounces simulate_scene",
        "synth.physics.contact": "ImpactResult solve_contact solve_impact",
        "synth.physics.materials": "LossFactor Material Rayleigh",
        "synth.physics.scene": "Accelerometer Ball Contact HollowBall Microphone Plate Scene",
        "synth.sound.render": "Render render",
        "synth.sound.result": "RenderInfo",
        "synth.sound.options": "RenderOptions",
    }.items()
    for name in names.split()
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
