"""Deformers: numpy in, numpy out (no GL, no scene objects)."""
from puppet.deform.arap import ArapData, arap_energy, arap_precompute, arap_solve
from puppet.deform.depth import depth_field
from puppet.deform.mls import mls_deform, mls_object_space

__all__ = [
    "ArapData",
    "arap_precompute",
    "arap_solve",
    "arap_energy",
    "mls_deform",
    "mls_object_space",
    "depth_field",
]
