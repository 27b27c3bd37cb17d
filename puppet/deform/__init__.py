"""Deformers: numpy in, numpy out (no GL, no scene objects)."""
from puppet.deform.anderson import AndersonInfo, arap_solve_anderson
from puppet.deform.arap import ArapData, arap_energy, arap_precompute, arap_solve
from puppet.deform.boundary import exterior_frame, exterior_positions, fine_deform
from puppet.deform.depth import depth_field
from puppet.deform.igarashi import IgarashiData, igarashi_precompute, igarashi_solve
from puppet.deform.mls import mls_deform, mls_from_weights, mls_object_space
from puppet.deform.mls_lines import mls_deform_lines
from puppet.deform.relax import folded_triangles, relax_foldovers
from puppet.deform.rotate import arap_solve_rotated, rotation_initial_guess
from puppet.deform.skeleton import SkeletonData, mls_skeleton, skeleton_precompute, skeleton_solve

__all__ = [
    "ArapData", "arap_precompute", "arap_solve", "arap_energy",
    "arap_solve_anderson", "AndersonInfo",
    "arap_solve_rotated", "rotation_initial_guess",
    "folded_triangles", "relax_foldovers",
    "IgarashiData", "igarashi_precompute", "igarashi_solve",
    "mls_deform", "mls_deform_lines", "mls_object_space", "mls_from_weights",
    "SkeletonData", "skeleton_precompute", "skeleton_solve", "mls_skeleton",
    "exterior_frame", "exterior_positions", "fine_deform",
    "depth_field",
]
