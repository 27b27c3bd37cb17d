"""Rendering with moderngl: the offscreen EGL context (or the app window's), the GLSL
programs of the top-level ``shaders/`` folder, and the compositor that draws every layer's
deformed mesh and sorts fragments per pixel by interpolated depth. Imports ``scene`` and
below; nothing here knows the app."""
