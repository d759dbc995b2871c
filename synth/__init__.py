"""Physically based synthesis of bouncing and impact sounds.

A ball is dropped on a plate; every impact is computed from the materials and
sizes (Hertz contact against the plate's mechanical impedance, with gravity),
strung together by a bounce scheduler, and heard through a modal model of the
finite plate. SI units throughout.

Heavy optional parts (plotting, playback, loudness, distributed batches) are
imported only where used.
"""

from synth import jitcache  # noqa: F401  (first: picks numba's cache folder before numba loads)
from synth.analysis import Analysis, Tick, analyze, analyze_file
from synth.errors import ParameterError, SynthError
from synth.io.audio import read_audio, write_audio
from synth.io.playback import play
from synth.io.presets import load_preset, render_preset
from synth.live import Body, Engine, EngineStats
from synth.physics import contact, materials
from synth.physics.bounces import BounceSequence, Impact, simulate_bounces, simulate_scene
from synth.physics.contact import ImpactResult, solve_contact, solve_impact
from synth.physics.materials import LossFactor, Material, Rayleigh
from synth.physics.scene import Accelerometer, Ball, Contact, Microphone, Plate, Scene
from synth.sound import modes as plate  # the plate's modes (kept under its public name)
from synth.sound.render import Render, render

__all__ = [
    "Accelerometer",
    "Analysis",
    "Ball",
    "Body",
    "BounceSequence",
    "Contact",
    "Engine",
    "EngineStats",
    "Impact",
    "ImpactResult",
    "LossFactor",
    "Material",
    "Microphone",
    "ParameterError",
    "Plate",
    "Rayleigh",
    "Scene",
    "Render",
    "SynthError",
    "Tick",
    "analyze",
    "analyze_file",
    "contact",
    "load_preset",
    "materials",
    "plate",
    "play",
    "read_audio",
    "render",
    "render_preset",
    "simulate_bounces",
    "simulate_scene",
    "solve_contact",
    "solve_impact",
    "write_audio",
]
__version__ = "0.2.0"


def __getattr__(name):
    # synth.bank (sound banks) is imported on first use: it is not needed to render.
    if name == "bank":
        import importlib

        return importlib.import_module("synth.bank")
    raise AttributeError(f"module 'synth' has no attribute {name!r}")
