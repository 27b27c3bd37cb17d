"""Sprite sheets: every frame of an animation in one PNG, plus a JSON atlas in the
TexturePacker "hash" form that Phaser (``load.atlas``) and PixiJS (``Spritesheet``) read.

Frames are laid out in a grid, left to right then top to bottom, at full size (no
trimming, no rotation). The PNG is written as the frames come: one row of frames is held
(``h x cols*w x 4`` bytes), filtered ("Up") and deflated into the file before the next row
begins, so memory does not depend on the number of frames. Sheets wider or taller than
:data:`MAX_SIDE` pixels are refused before anything is drawn (most GPUs cannot hold a
larger texture anyway).
"""
from __future__ import annotations

import json
import math
import struct
import zlib
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np

#: Largest sheet side in pixels (the texture size WebGL guarantees on most desktop GPUs).
MAX_SIDE = 8192
#: zlib level of the sheet's image data (1 fastest .. 9 smallest).
LEVEL = 6


@dataclass(frozen=True)
class Layout:
    """Where each of ``n`` frames of ``w`` x ``h`` pixels goes: a grid of ``cols`` x ``rows``."""

    n: int
    w: int
    h: int
    cols: int
    rows: int

    @property
    def size(self) -> tuple[int, int]:
        """Sheet (width, height) in pixels."""
        return self.cols * self.w, self.rows * self.h

    def place(self, i: int) -> tuple[int, int]:
        """Top-left (x, y) of frame ``i``."""
        return (i % self.cols) * self.w, (i // self.cols) * self.h


def layout(n: int, w: int, h: int, max_side: int | None = None) -> Layout | None:
    """A near-square grid for ``n`` frames of ``w`` x ``h``, or None when no grid fits in
    ``max_side`` x ``max_side`` (default :data:`MAX_SIDE`)."""
    max_side = MAX_SIDE if max_side is None else max_side
    if n < 1 or w > max_side or h > max_side:
        return None
    most = max_side // w  # frames per row at most
    cols = min(n, most, max(1, math.ceil(math.sqrt(n * h / w))))
    rows = math.ceil(n / cols)
    if rows * h > max_side:  # as wide as allowed, fewest rows
        cols = min(n, most)
        rows = math.ceil(n / cols)
        if rows * h > max_side:
            return None
    return Layout(n, w, h, cols, rows)


def frame_name(i: int) -> str:
    """The atlas key of frame ``i`` (the same name as in a frame folder)."""
    return f"frame_{i:05d}.png"


def atlas(lay: Layout, image: str, fps: float) -> dict:
    """The TexturePacker JSON-hash atlas of a sheet.

    Each frame also carries ``duration`` (milliseconds, as Aseprite writes it), and
    ``animations`` lists the frames in order (PixiJS makes an ``AnimatedSprite`` of it).
    """
    frames = {}
    for i in range(lay.n):
        x, y = lay.place(i)
        frames[frame_name(i)] = {
            "frame": {"x": x, "y": y, "w": lay.w, "h": lay.h},
            "rotated": False, "trimmed": False,
            "spriteSourceSize": {"x": 0, "y": 0, "w": lay.w, "h": lay.h},
            "sourceSize": {"w": lay.w, "h": lay.h},
            "duration": round(1000.0 / fps, 3),
        }
    w, h = lay.size
    return {"frames": frames, "animations": {"animation": list(frames)},
            "meta": {"app": "puppet", "version": "1", "image": image, "format": "RGBA8888",
                     "size": {"w": w, "h": h}, "scale": "1", "frameRate": fps}}


def atlas_text(lay: Layout, image: str, fps: float) -> str:
    return json.dumps(atlas(lay, image, fps), indent=1) + "\n"


def _chunk(fp: BinaryIO, kind: bytes, data: bytes) -> None:
    fp.write(struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data)))


def write_png(fp: BinaryIO, rgba: np.ndarray, level: int = 1) -> None:
    """One (h, w, 4) uint8 RGBA image as a PNG ("Up" filter, zlib ``level``): at level 1
    about 4x less CPU than Pillow's adaptive filters at 1280x720, for a file ~10 % larger."""
    h, w = rgba.shape[:2]
    out = SheetWriter(fp, Layout(1, w, h, 1, 1), level=level)
    out.add(rgba)
    out.close()


class SheetWriter:
    """Write a sprite sheet PNG (RGBA, 8 bits) frame by frame.

    Parameters
    ----------
    fp : binary file open for writing.
    lay : the grid; frames must come in order, each (h, w, 4) uint8 straight RGBA.
    level : zlib level.
    """

    def __init__(self, fp: BinaryIO, lay: Layout, level: int = LEVEL):
        self.fp, self.lay = fp, lay
        W, H = lay.size
        fp.write(b"\x89PNG\r\n\x1a\n")
        _chunk(fp, b"IHDR", struct.pack(">IIBBBBB", W, H, 8, 6, 0, 0, 0))
        self._z = zlib.compressobj(level)
        self._band = np.zeros((lay.h, W, 4), np.uint8)  # one row of frames
        self._above = np.zeros((W * 4,), np.uint8)  # the last scanline written
        self._rows = 0  # bands written
        self.frames = 0

    def add(self, rgba: np.ndarray) -> None:
        """Place the next frame; a full row of frames goes to the file."""
        lay = self.lay
        if rgba.shape != (lay.h, lay.w, 4):
            raise ValueError(f"frame is {rgba.shape}, the sheet's frames are {(lay.h, lay.w, 4)}")
        if self.frames >= lay.n:
            raise ValueError(f"the sheet holds {lay.n} frames")
        x, _ = lay.place(self.frames)
        self._band[:, x:x + lay.w] = rgba
        self.frames += 1
        if self.frames % lay.cols == 0:
            self._flush_band()

    def _flush_band(self) -> None:
        lines = self._band.reshape(self.lay.h, -1)
        up = np.empty((lines.shape[0], lines.shape[1] + 1), np.uint8)
        up[:, 0] = 2  # PNG filter "Up": each byte minus the byte above it (mod 256)
        up[0, 1:] = lines[0] - self._above
        up[1:, 1:] = lines[1:] - lines[:-1]
        self._above = lines[-1].copy()
        self._emit(self._z.compress(up.tobytes()))
        self._band[:] = 0
        self._rows += 1

    def _emit(self, data: bytes) -> None:
        if data:
            _chunk(self.fp, b"IDAT", data)

    def close(self) -> None:
        """Write the last (partial) row, the empty rows left and the end of the file."""
        if self.frames != self.lay.n:
            raise ValueError(f"{self.frames} frames given, the sheet holds {self.lay.n}")
        if self.frames % self.lay.cols:
            self._flush_band()
        while self._rows < self.lay.rows:  # (not reached with a tight grid)
            self._flush_band()
        self._emit(self._z.flush())
        _chunk(self.fp, b"IEND", b"")
