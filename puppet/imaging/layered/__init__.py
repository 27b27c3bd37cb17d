"""Layered art files read as a stack of layers: PSD/PSB, OpenRaster (ORA), Krita (KRA).

:func:`read_layered` returns a :class:`LayeredArt`: the document's size and its visible
pixel layers, back to front, each cropped to its pixels (straight-alpha 8-bit RGBA) at
its offset on the canvas, with everything the puppet format cannot express baked into
the pixels (layer and group opacity, masks, clipping masks, effects the reader can draw)
and a note for each thing left out. Names: a layer inside groups is named
``group/sub/layer``; ``[merge]`` in a group's name makes the group one layer and
``[ignore]`` in any name skips that layer or group (tags are dropped from the names).

Nothing here modifies the art file; every size is checked against
:data:`puppet.imaging.io.MAX_SIDE` / :data:`~puppet.imaging.io.MAX_PIXELS` before its
pixels are decoded, the whole import against the totals of :mod:`.art` (layers, pixels
in all, KRA tile work; :class:`~.art.Totals`) from the headers before any layer is
decoded, and zip members are read with bounded sizes. Every bad file is one
:class:`~puppet.errors.ImageError` line.

Modules: :mod:`.art` (the layer types and the helpers every reader shares), :mod:`.read`
(the reader picked by suffix), one reader each in :mod:`.psd`, :mod:`.ora`, :mod:`.kra`,
and their parts :mod:`.blend`, :mod:`.adjust` (PSD adjustment layers), :mod:`.zipped`
(ORA/KRA zip members). This package only gathers their public names.
"""
from puppet.imaging.layered.art import (ArtLayer, LayeredArt, apply_mask, check_regular, check_size, cropped,
                                        flatten, over, scale_alpha, split_tags, to_rgba, to_uint8, unique, why)
from puppet.imaging.layered.read import SUFFIXES, is_layered, read_layered

__all__ = ["ArtLayer", "LayeredArt", "SUFFIXES", "apply_mask", "check_regular", "check_size", "cropped", "flatten",
           "is_layered", "over", "read_layered", "scale_alpha", "split_tags", "to_rgba", "to_uint8", "unique", "why"]
