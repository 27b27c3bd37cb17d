"""GLSL programs of puppet's renderer, one file per program (packaged as data)."""
