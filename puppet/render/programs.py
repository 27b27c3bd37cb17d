"""Loading of the GLSL programs in the top-level ``shaders/`` folder.

File scheme
-----------
One file ``NAME.glsl`` per program. Its first line is the ``#version`` directive; the
stages follow, each inside a preprocessor block::

    #version 330 core
    #if defined VERTEX_SHADER
    ...
    #elif defined FRAGMENT_SHADER
    ...
    #endif

For each stage the file tests (``#if defined``/``#elif defined``/``#ifdef`` of
``VERTEX_SHADER``, ``GEOMETRY_SHADER`` or ``FRAGMENT_SHADER``), the loader compiles the
whole file with ``#define <STAGE>`` (plus any variant defines) and ``#line 2`` inserted
right after the ``#version`` line, so compiler messages give the file's line numbers.

The folder is the package ``puppet.shaders`` (``package-dir`` in pyproject.toml), read
with :func:`importlib.resources.files`, so it works from an installed wheel and from an
editable install. In a plain source checkout (repository root on ``sys.path``, nothing
installed) ``puppet.shaders`` is not importable because the folder lives at the root,
next to ``puppet/``; the loader then falls back to that folder.
"""
from __future__ import annotations

import importlib.resources
import math
import re
import weakref
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

import moderngl

if TYPE_CHECKING:  # importlib.resources.abc is Python 3.11+
    from importlib.abc import Traversable

STAGES = {"VERTEX_SHADER": "vertex_shader", "GEOMETRY_SHADER": "geometry_shader",
          "FRAGMENT_SHADER": "fragment_shader"}

_programs: "weakref.WeakKeyDictionary[moderngl.Context, dict[tuple, moderngl.Program]]" = (
    weakref.WeakKeyDictionary())


def shader_dir() -> Traversable:
    """Folder holding the ``*.glsl`` files.

    Returns
    -------
    importlib.resources.abc.Traversable
        ``importlib.resources.files("puppet.shaders")``, or the ``shaders/`` folder of
        the source tree when that package is not importable.
    """
    try:
        return importlib.resources.files("puppet.shaders")
    except ModuleNotFoundError:
        source_tree = Path(__file__).resolve().parents[2] / "shaders"
        if (source_tree / "__init__.py").is_file():
            return source_tree
        raise


def shader_source(name: str) -> str:
    """Text of ``shaders/NAME.glsl``.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    """
    resource = shader_dir().joinpath(f"{name}.glsl")
    if not resource.is_file():
        raise FileNotFoundError(f"no shader program {name!r} ({name}.glsl) in puppet.shaders")
    return resource.read_text(encoding="utf-8")


def glsl_literal(value: object) -> str:
    """A define's value as GLSL text: floats keep a decimal point or exponent (``1.0``,
    ``0.00196078431372549``), bools become 1/0, anything else its ``str``."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"a GLSL define cannot be {value}")
        text = repr(value)
        return text if any(ch in text for ch in ".e") else text + ".0"
    return str(value)


def split_stages(source: str, name: str = "<string>", *,
                 defines: Mapping[str, object] | None = None) -> dict[str, str]:
    """Per-stage sources of a one-file program.

    Parameters
    ----------
    source : str
        File text; its first non-blank line must be ``#version ...``.
    name : str, optional
        Program name, for error messages.
    defines : mapping of str to object, optional
        Extra ``#define NAME VALUE`` lines inserted with the stage define (program
        variants and constants shared with Python, e.g. ``{"OPAQUE_PASS": 1,
        "ALPHA_MIN": 0.5 / 255}``; values through :func:`glsl_literal`).

    Returns
    -------
    dict of str to str
        Keyword arguments for :meth:`moderngl.Context.program`
        (``vertex_shader``, ``fragment_shader`` and, if present, ``geometry_shader``).
    """
    lines = source.splitlines()
    first = next((i for i, line in enumerate(lines) if line.strip()), None)
    if first is None or not lines[first].lstrip().startswith("#version"):
        raise ValueError(f"shader {name}: the first line must be a #version directive")
    head, body = lines[: first + 1], lines[first + 1:]
    extra = [f"#define {key} {glsl_literal(value)}" for key, value in sorted((defines or {}).items())]
    stages = {}
    for define, keyword in STAGES.items():
        if re.search(rf"^\s*#\s*(?:(?:el)?if\s+defined\s*\(?\s*|ifdef\s+){define}\b",
                     source, re.MULTILINE):
            text = head + [f"#define {define}", *extra, f"#line {first + 2}"] + body
            stages[keyword] = "\n".join(text) + "\n"
    if "vertex_shader" not in stages:
        raise ValueError(f"shader {name}: no VERTEX_SHADER section")
    return stages


def load_program(ctx: moderngl.Context, name: str, *,
                 defines: Mapping[str, object] | None = None) -> moderngl.Program:
    """Compile ``shaders/NAME.glsl`` once per context and return the program.

    Parameters
    ----------
    ctx : moderngl.Context
        Context the program belongs to (current on this thread).
    name : str
        File name without ``.glsl``.
    defines : mapping of str to object, optional
        Preprocessor defines selecting a variant of the program; each distinct set is
        compiled and cached separately.

    Returns
    -------
    moderngl.Program
        The same object on every call with the same context, name and defines. It is
        released with the context (or explicitly: see :func:`forget_programs`).
    """
    cache = _programs.setdefault(ctx, {})
    key = (name, tuple(sorted((k, str(v)) for k, v in (defines or {}).items())))
    program = cache.get(key)
    if program is None:
        program = ctx.program(**split_stages(shader_source(name), name, defines=defines))
        cache[key] = program
    return program


def forget_programs(ctx: moderngl.Context, *, release: bool = False) -> None:
    """Drop the cached programs of a context, releasing them if ``release``."""
    for program in _programs.pop(ctx, {}).values():
        if release:
            program.release()


def set_uniform(program: moderngl.Program, name: str, value: Any) -> bool:
    """Set a uniform if the linked program still has it.

    Mesa removes uniforms the compiler finds unused, and looking them up then raises
    ``KeyError``; this writes only when the uniform exists.

    Returns
    -------
    bool
        True when the uniform exists and was written.
    """
    member = program.get(name, None)
    if member is None:
        return False
    member.value = value
    return True
