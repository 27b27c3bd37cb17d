"""Deformers: numpy in, numpy out (no GL, no scene objects)."""
import importlib

_WHERE = {  # name -> submodule
    "AndersonInfo": "anderson", "arap_solve_anderson": "anderson", "ArapData": "arap",
    "arap_energy": "arap", "arap_precompute": "arap", "arap_solve": "arap",
    "exterior_frame": "boundary", "exterior_positions": "boundary", "fine_deform": "boundary",
    "depth_field": "depth", "IgarashiData": "igarashi", "igarashi_precompute": "igarashi",
    "igarashi_solve": "igarashi", "mls_deform": "mls", "mls_from_weights": "mls",
    "mls_object_space": "mls", "mls_deform_lines": "mls_lines", "folded_triangles": "relax",
    "relax_foldovers": "relax", "arap_solve_rotated": "rotate", "rotation_initial_guess": "rotate",
    "SkeletonData": "skeleton", "mls_skeleton": "skeleton", "skeleton_precompute": "skeleton",
    "skeleton_solve": "skeleton",
}

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


def __getattr__(name: str):
    # lazy: a command imports only the deformers its scene uses (each costs its share of the start)
    if name in _WHERE:
        value = getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
