"""Physically based synthesis of bouncing and impact sounds, in SI units: Hertz contact against
the plate's impedance, a bounce scheduler and a modal model of the finite plate. Every public
name is imported on first use (PEP 562), so ``import synth`` loads no numerical library."""

from synth import jitcache  # noqa: F401  (first: picks numba's cache folder before numba loads)
from synth.errors import ParameterError, SynthError  # noqa: F401  (in __all__)
from synth.lazy import lazy_names

#: Where each public name lives (below ``synth``): imported from there on first use.
_LAZY = {
    name: module
    for module, names in {
        "analysis": "Analysis AnalysisOptions Tick analyze analyze_file",
        "store.audio": "read_audio write_audio",
        "io.playback": "play",
        "io.presets": "load_preset render_preset",
        "live": "Body Engine EngineStats Voice",
        "physics.bounces": "BounceSequence Impact simulate_bounces simulate_scene",
        "physics.contact": "ImpactResult solve_contact solve_impact",
        "physics.materials": "LossFactor Material Rayleigh",
        "physics.scene": "Accelerometer Ball Contact HollowBall Microphone Plate Scene",
        "sound.render": "Render render",
        "sound.result": "RenderInfo",
        "sound.options": "RenderOptions",
    }.items()
    for name in names.split()
}
#: Public submodules, imported on first use; ``plate`` is the plate's modes under its
#: public name.
_SUBMODULES = {
    "contact": "physics.contact",
    "materials": "physics.materials",
    "plate": "physics.modes",
    "bank": "bank",
}

#: ``from synth import *`` takes every public name but the sound banks (imported by name).
__all__ = sorted(["ParameterError", "SynthError", *_LAZY, *(_SUBMODULES.keys() - {"bank"})])
__version__ = "0.4.0"

__getattr__, __dir__ = lazy_names(__name__, _LAZY, _SUBMODULES)
