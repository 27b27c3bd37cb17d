"""A streaming GIF writer: frames go to the file one at a time, memory stays flat.

Pillow's multi-frame GIF writer keeps every frame until the end (to merge duplicates),
so a long animation needs memory in proportion to its length. Here the file is written
as frames arrive, with one global palette chosen up front (from a sample of frames),
and only the previous frame kept:

- each frame is stored as the rectangle where it differs from the previous one
  (disposal "do not dispose", so the rest stays on screen);
- a frame equal to the previous one only lengthens the previous frame's delay, which is
  why one encoded frame is held back until the next one is known;
- delays are whole hundredths of a second (what GIF stores), rounded so that frame
  *i* ends at ``round(100 (i + 1) / fps)``: the total length is exact; a delay is at least
  2/100 s (browsers slow shorter ones down to 1/10 s), so above 50 fps a GIF plays slower.

With ``transparent`` (a palette index), frames may hold see-through pixels: each frame is
then stored as the box around its visible pixels and disposed ("restore to background")
before the next, since a frame drawn over the previous one could never make a pixel
clear again.

The image data is LZW-coded by Pillow (``GifImagePlugin.getdata``).
"""
from __future__ import annotations

import struct
from typing import BinaryIO

import numpy as np

#: Shortest delay written, hundredths of a second (shorter ones play at 1/10 s in browsers).
MIN_DELAY = 2
#: Longest delay one frame can hold (16 bits).
MAX_DELAY = 65535


def palette_from_sample(sample: np.ndarray, colors: int = 256):
    """An adaptive palette (median cut) of at most ``colors`` colours for RGB pixels.

    Parameters
    ----------
    sample : (h, w, 3) uint8 array of pixels standing for the whole animation.
    colors : 2..256; 255 leaves the last index free for transparency.

    Returns
    -------
    PIL.Image.Image in mode ``P`` whose palette is the one to quantize every frame with.
    """
    from PIL import Image

    return Image.fromarray(np.ascontiguousarray(sample)).quantize(colors=colors, method=Image.Quantize.MEDIANCUT)


def quantize(rgb: np.ndarray, palette) -> np.ndarray:
    """Palette indices of an (h, w, 3) uint8 frame, nearest colour, no dithering -> (h, w) uint8."""
    from PIL import Image

    return np.asarray(Image.fromarray(np.ascontiguousarray(rgb)).quantize(palette=palette,
                                                                          dither=Image.Dither.NONE))


class GifStream:
    """Write a looping GIF frame by frame.

    Parameters
    ----------
    fp : binary file open for writing.
    size : (width, height) of every frame, each 1..65535.
    palette : PIL ``P`` image (see :func:`palette_from_sample`); frames index its colours.
    fps : frames per second.
    transparent : palette index drawn as see-through (None: every pixel is opaque).
    """

    def __init__(self, fp: BinaryIO, size: tuple[int, int], palette, fps: float, transparent: int | None = None):
        w, h = size
        if not (1 <= w <= 65535 and 1 <= h <= 65535):
            raise ValueError(f"GIF frames are 1..65535 pixels per side, got {w}x{h}")
        self.fp, self.size, self.fps, self.transparent = fp, (w, h), float(fps), transparent
        colours = bytes(palette.getpalette("RGB") or b"")[:768]
        colours += bytes(768 - len(colours))
        bg = 0 if transparent is None else int(transparent)  # what "restore to background" shows
        fp.write(b"GIF89a" + struct.pack("<HHBBB", w, h, 0xF7, bg, 0) + colours)  # 256-colour global table
        fp.write(b"!\xff\x0bNETSCAPE2.0\x03\x01" + struct.pack("<H", 0) + b"\x00")  # loop for ever
        self._prev: np.ndarray | None = None  # indices on screen after the held frame
        self._held: list[bytes] | None = None  # encoded rectangle not written yet
        self._delay = 0  # its delay so far, 1/100 s
        self.frames_added = 0
        #: frames stored in the file (equal consecutive frames are stored once)
        self.frames_written = 0

    def _end_cs(self, i: int) -> int:
        """When frame ``i`` ends, in hundredths of a second."""
        return int(round(100.0 * (i + 1) / self.fps))

    def add(self, index: np.ndarray) -> None:
        """Add a frame given as (h, w) uint8 palette indices."""
        h, w = index.shape
        if (w, h) != self.size:
            raise ValueError(f"frame is {w}x{h}, the GIF is {self.size[0]}x{self.size[1]}")
        i = self.frames_added
        self.frames_added += 1
        step = self._end_cs(i) - (self._end_cs(i - 1) if i else 0)
        if self._prev is not None:
            diff = index != self._prev
            if not diff.any() and self._delay + step <= MAX_DELAY:
                self._delay += step
                return
        if self.transparent is not None:  # the previous frame is cleared: store what shows
            diff = index != self.transparent
        if self._prev is not None or self.transparent is not None:
            rows, cols = np.flatnonzero(diff.any(axis=1)), np.flatnonzero(diff.any(axis=0))
            if len(rows):
                y0, y1, x0, x1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
            else:  # equal, but the held delay is full (or nothing shows): one pixel
                y0, y1, x0, x1 = 0, 1, 0, 1
        else:
            y0, y1, x0, x1 = 0, h, 0, w
        self._flush()
        self._held = self._encode(index[y0:y1, x0:x1], (int(x0), int(y0)))
        self._delay = step
        self._prev = index.copy()

    def _encode(self, rect: np.ndarray, offset: tuple[int, int]) -> list[bytes]:
        from PIL import GifImagePlugin, Image

        im = Image.fromarray(np.ascontiguousarray(rect))  # mode L: the bytes are the indices
        return GifImagePlugin.getdata(im, offset=offset)

    def _flush(self) -> None:
        if self._held is None:
            return
        delay = min(max(self._delay, MIN_DELAY), MAX_DELAY)
        if self.transparent is None:
            self.fp.write(b"!\xf9\x04\x04" + struct.pack("<H", delay) + b"\x00\x00")  # disposal 1: keep
        else:  # disposal 2 (restore to background), transparent index given
            self.fp.write(b"!\xf9\x04\x09" + struct.pack("<HB", delay, self.transparent) + b"\x00")
        for chunk in self._held:
            self.fp.write(chunk)
        self._held = None
        self.frames_written += 1

    def close(self) -> None:
        """Write the held frame and the trailer (the file object stays open)."""
        self._flush()
        self.fp.write(b";")
