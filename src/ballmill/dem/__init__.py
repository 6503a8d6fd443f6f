"""Discrete element engine: Hertz-Mindlin spheres and moving rigid walls in Taichi."""

from .checkpoint import Checkpoint, SettledBed
from .engine import Engine, EngineOptions, SimulationError, memory_estimate_bytes, new_engine
from .geometry import Body, Capsule, Cylinder, Mesh, Motion, Plane
from .materials import Interaction, Material
from .results import ParquetSink, Recorder, Results
from .runtime import available_memory_bytes, init_taichi
from .system import SystemSpec

__all__ = [
    "Body", "Capsule", "Checkpoint", "Cylinder", "Engine", "EngineOptions", "Interaction", "Material", "Mesh",
    "Motion", "ParquetSink", "Plane", "Recorder", "Results", "SettledBed", "SimulationError", "SystemSpec", "available_memory_bytes", "init_taichi", "memory_estimate_bytes", "new_engine",
]
