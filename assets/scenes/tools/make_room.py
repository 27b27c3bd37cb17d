"""Generate the dressing room's scenes and pictures in ``assets/scenes/room/``
(docs/dressroom.md): a mannequin from Kenney's skin-coloured character parts and seven
garments on its 700 x 720 canvas, at the offsets of ``assets/scenes/character.json``.

Run from anywhere::

    .venv/bin/python assets/scenes/tools/make_room.py

Pictures it makes: the mannequin's torso and hips (the red jumper's and the waistband's
alpha, filled with the skin colour of ``tint1_neck.png``); left-side copies of the short
sleeve and the short trouser leg (flipped left-right); the noto dress and t-shirt scaled
to 0.7 and 0.6 (Lanczos), their pins scaled with them and a ``fit`` pose that puts them
on the mannequin (the t-shirt's hem pins at depth -1, so that it tucks into a bottom).
"""
from __future__ import annotations

import json
import os

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.dirname(HERE)
ROOM = os.path.join(SCENES, "room")
ASSETS = os.path.dirname(SCENES)
K = "../../kenney-character/"
SKIN = (245, 210, 157)  # tint1_neck.png's one opaque colour
CANVAS = [700, 720]


def kenney(name: str) -> Image.Image:
    return Image.open(os.path.join(ASSETS, "kenney-character", name)).convert("RGBA")


def skin(src: str, out: str) -> None:
    a = np.asarray(kenney(src))[..., 3]
    im = np.zeros(a.shape + (4,), np.uint8)
    im[..., :3], im[..., 3] = SKIN, a
    Image.fromarray(im).save(os.path.join(ROOM, out), optimize=True)


def layer(name, image, offset, **kw) -> dict:
    return {"name": name, "image": image, "offset": offset, **kw}


def write(name: str, doc: dict) -> None:
    with open(os.path.join(ROOM, name + ".json"), "w") as f:
        f.write(json.dumps(doc, indent=1) + "\n")


def scaled(src: str, png: str, out: str, s: float, off, layer_name: str) -> tuple[dict, list]:
    """The emoji garment ``png`` scaled by ``s`` as ``out``, its layer at ``off`` and the
    pins of scene ``src`` moved with it."""
    im = Image.open(os.path.join(ASSETS, "noto-emoji", png)).convert("RGBA")
    n = round(im.size[0] * s)
    im.resize((n, n), Image.LANCZOS).save(os.path.join(ROOM, out), optimize=True)
    with open(os.path.join(SCENES, src + ".json")) as f:
        pins = json.load(f)["pins"]
    pins = [{**p, "at": [round(p["at"][0] * s + off[0], 1), round(p["at"][1] * s + off[1], 1)]} for p in pins]
    return layer(layer_name, out, off, mask="alpha", mesh={"max_area": 30}), pins


def main() -> None:
    os.makedirs(ROOM, exist_ok=True)
    skin("redShirt1.png", "mannequin-torso.png")
    skin("pantsLightBlue3.png", "mannequin-hips.png")
    for name in ("blueArm_short", "pantsBrown_short"):
        kenney(name + ".png").transpose(Image.FLIP_LEFT_RIGHT).save(os.path.join(ROOM, name + "-mirrored.png"),
                                                                     optimize=True)
    base = {"puppet": 1, "canvas": CANVAS}
    write("mannequin", {**base, "background": [84, 150, 200, 255], "layers": [
        layer("leg_l", K + "mirrored/tint1_leg.png", [251, 425]), layer("leg_r", K + "tint1_leg.png", [356, 425]),
        layer("arm_l", K + "mirrored/tint1_arm.png", [137, 256]), layer("arm_r", K + "tint1_arm.png", [393, 256]),
        layer("hand_l", K + "mirrored/tint1_hand.png", [118, 360]), layer("hand_r", K + "tint1_hand.png", [521, 360]),
        layer("neck", K + "tint1_neck.png", [302, 246]), layer("torso", "mannequin-torso.png", [274, 250]),
        layer("hips", "mannequin-hips.png", [274, 402]),
        layer("head", K + "tint1_head.png", [264, 86]), layer("face", K + "face1.png", [301, 133]),
        layer("hair", K + "brown2Man5.png", [273, 48])]})
    write("red-jumper", {**base, "garment": {"name": "red jumper", "category": "top"}, "layers": [
        layer("shirt", K + "redShirt1.png", [274, 250]), layer("sleeve_l", K + "mirrored/redArm_long.png", [137, 256]),
        layer("sleeve_r", K + "redArm_long.png", [392, 256])]})
    # left parts mirror right ones about x = 350: x_left = 700 - (x_right + width)
    write("blue-tee", {**base, "garment": {"name": "blue tee", "category": "top"}, "layers": [
        layer("shirt", K + "blueShirt1.png", [274, 250]), layer("sleeve_l", "blueArm_short-mirrored.png", [189, 256]),
        layer("sleeve_r", K + "blueArm_short.png", [393, 256])]})
    write("jeans", {**base, "garment": {"category": "bottom"}, "layers": [
        layer("leg_l", K + "mirrored/pantsLightBlue_long.png", [239, 422]),
        layer("leg_r", K + "pantsLightBlue_long.png", [350, 422]),
        layer("waist", K + "pantsLightBlue3.png", [274, 402])]})
    write("shorts", {**base, "garment": {"category": "bottom"}, "layers": [
        layer("leg_l", "pantsBrown_short-mirrored.png", [243, 422]),
        layer("leg_r", K + "pantsBrown_short.png", [350, 422]),
        layer("waist", K + "pantsLightBlue3.png", [274, 402])]})
    write("shoes", {**base, "garment": {"category": "shoes"}, "layers": [
        layer("shoe_l", K + "mirrored/brownShoe5.png", [220, 575]), layer("shoe_r", K + "brownShoe5.png", [386, 575])]})
    dress, pins = scaled("dress-garment", "emoji_u1f457.png", "dress.png", 0.7, [176, 241], "dress")
    write("dress", {**base, "garment": {"category": "dress"}, "layers": [dress], "pins": pins, "poses": {"fit": {
        "waist_l": [321, 373], "waist_r": [387, 373], "hem_l": [256, 540], "hem_r": [478, 532]}}})
    shirt, pins = scaled("tshirt-garment", "emoji_u1f455.png", "t-shirt.png", 0.6, [196, 200], "shirt")
    write("t-shirt", {**base, "garment": {"category": "top", "name": "t-shirt"}, "layers": [shirt], "pins": pins,
                      "poses": {"fit": {
                          "shoulder_l": [292, 274], "shoulder_r": [408, 274], "sleeve_l": [222, 326],
                          "sleeve_r": [478, 326], "chest": [350, 332],
                          "hem_l": {"to": [290, 452], "depth": -1}, "hem_c": {"to": [350, 458], "depth": -1},
                          "hem_r": {"to": [410, 452], "depth": -1}}}})


if __name__ == "__main__":
    main()
