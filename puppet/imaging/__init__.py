"""Images, numpy + OpenCV + Pillow (no GL): reading pictures with size limits (:mod:`.io`,
:mod:`.decode`), masks, GrabCut, inpainting, cut-outs, the skeleton of a mask (automatic
pins), video frames, and layered art files (:mod:`.layered`: PSD/PSB, ORA, KRA)."""
