"""Physically based synthesis of bouncing and impact sounds.

A ball is dropped on a plate; every impact is computed from the materials and
sizes (Hertz contact against the plate's mechanical impedance, with gravity),
strung together by a bounce scheduler, and heard through a modal model of the
finite plate. SI units throughout.
"""

from .errors import ParameterError, SynthError
from .materials import LossFactor, Material, Rayleigh
from .scene import Accelerometer, Ball, Microphone, Plate, Scene

__all__ = [
    "Accelerometer", "Ball", "LossFactor", "Material", "Microphone", "ParameterError",
    "Plate", "Rayleigh", "Scene", "SynthError",
]
__version__ = "0.1.0"
