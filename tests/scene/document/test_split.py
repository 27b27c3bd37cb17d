"""Layer via Cut / Layer via Copy (``scene.split_layer``): a disc with a bar stuck on it."""
import json
import os

import numpy as np
import pytest
from scipy import ndimage

import puppet
from puppet.imaging.cutout import arc_bezier, body_after_cut, fit_tangent

W, H = 200, 170
DISC, BAR, WHITE = (200, 60, 40), (40, 90, 200), (255, 255, 255)
#: a polygon around all of the bar (its part inside the disc too)
AROUND_BAR = [[106, 69], [189, 69], [189, 92], [106, 92]]


def shapes():
    yy, xx = np.mgrid[:H, :W]
    disc = (xx - 90) ** 2 + (yy - 80) ** 2 <= 50 ** 2
    bar = (np.abs(yy - 80) <= 8) & (xx >= 110) & (xx <= 185)
    return disc, bar


def picture():
    disc, bar = shapes()
    a = np.full((H, W, 4), 255, np.uint8)
    a[disc, :3] = DISC
    a[bar, :3] = BAR
    return a


@pytest.fixture
def flat(make_scene):
    """One layer over a flat picture, the way `puppet init` / the app start."""
    s = {"puppet": 1, "source": "pic.png", "background": [255, 255, 255, 255],
         "layers": [{"name": "body"}]}
    return make_scene(s, {"pic.png": picture()})


def swing_bar_away(sc):
    """Pin the bar at its middle and move it down, clear of where it was."""
    sc.add_pin("grip", "bar", [150, 80])
    sc.set_target("grip", [150, 145])
    return sc.render()


def near(img, colour, tol):
    return np.linalg.norm(img[..., :3].astype(float) - colour, axis=-1) < tol


# -- the outline completion ------------------------------------------------------------------
def test_arc_bezier_reproduces_a_quarter_circle():
    b = arc_bezier([1, 0], [0, 1], [0, 1], [-1, 0], 64)
    assert np.abs(np.hypot(*b.T) - 1).max() < 3e-4
    line = arc_bezier([0, 0], [1, 0], [9, 0], [1, 0], 10)
    np.testing.assert_allclose(line[:, 1], 0, atol=1e-12)
    np.testing.assert_allclose(line[:, 0], np.linspace(0, 9, 10), atol=1e-12)  # h = c/3: uniform speed


def test_fit_tangent_on_a_circle_and_a_line():
    th = np.linspace(0, 0.6, 12)
    Q = np.column_stack([30 * np.cos(th), 30 * np.sin(th)])
    t = fit_tangent(Q)
    np.testing.assert_allclose(t, [-np.sin(0.6), np.cos(0.6)], atol=1e-9)
    np.testing.assert_allclose(fit_tangent([[0, 0], [1, 1], [2, 2], [3, 3]]), [2 ** -0.5, 2 ** -0.5], atol=1e-9)


def test_completion_gives_the_disc_back():
    disc, bar = shapes()
    mask = disc | bar
    region = np.zeros_like(mask)
    region[69:92, 106:189] = True
    keep, refill = body_after_cut(mask, region & mask)
    assert not (keep & bar & ~ndimage.binary_dilation(disc)).any()  # what stuck out is gone (to a pixel)
    assert (keep ^ disc).sum() <= 0.01 * disc.sum()  # the round edge is back (8 px differ, 20 unsmoothed)
    assert (refill == (keep & region)).all()
    # a part wholly inside the body is refilled wholly; a band across it is bridged
    eye = disc & ((np.mgrid[:H, :W][1] - 80) ** 2 + (np.mgrid[:H, :W][0] - 70) ** 2 <= 64)
    keep, refill = body_after_cut(disc, eye)
    assert (keep == disc).all() and (refill == eye).all()
    band = disc & (np.abs(np.mgrid[:H, :W][0] - 80) <= 6)
    keep, _ = body_after_cut(disc, band)
    assert (keep ^ disc).sum() <= 0.02 * band.sum()



def test_fit_tangent_on_a_pixel_staircase_follows_the_edge():
    """16 pixels of a nearly vertical edge with one step (the gopher's body beside its arm):
    the algebraic circle fit gives a 4.6 px circle among them; the tangent is the edge's."""
    Q = [[220, y] for y in range(181, 173, -1)] + [[219, y] for y in range(173, 165, -1)]
    t = fit_tangent(Q)
    assert t[1] < -0.99  # upwards, along the points (was (0.998, -0.067), across the edge)


def test_completion_follows_an_ellipse_beside_a_cut_arm():
    """An upright ellipse (the gopher's body) with an arm stuck out of its side; a rectangle
    round the arm cuts into the body's edge above and below it: the completed edge stays
    within 1.2 px of the ellipse (it bit 3 px in when the tangents were fitted to the raw
    pixel staircase)."""
    yy, xx = np.mgrid[:300, :360]
    body = ((xx - 150) / 70.0) ** 2 + ((yy - 185) / 100.0) ** 2 <= 1
    arm = (np.abs(yy - 150) <= 13) & (xx >= 177) & (xx <= 316)
    region = (yy >= 135) & (yy <= 166) & (xx >= 176) & (xx <= 320)
    keep, _ = body_after_cut(body | arm, region & (body | arm))
    assert not (keep & arm & ~ndimage.binary_dilation(body)).any()
    for y in range(128, 172):
        edge = np.flatnonzero(keep[y]).max() + 0.5
        assert abs(edge - (150 + 70 * np.sqrt(1 - ((y - 185) / 100.0) ** 2))) < 1.2, y  # (1.05; 3.1 unsmoothed)

# -- the document edit -----------------------------------------------------------------------
@pytest.mark.gl
def test_cut_bar_leaves_background_and_refilled_body(flat):
    disc, bar = shapes()
    sc = puppet.load_scene(flat)
    assert sc.split_layer("body", AROUND_BAR, "bar") is True
    assert [L.name for L in sc.data.layers] == ["body", "bar"]
    img = swing_bar_away(sc)
    out = bar & ~disc  # where the bar stuck out
    differs = ~near(img, WHITE, 12)
    assert differs[out].mean() <= 0.02, differs[out].mean()
    inside = disc & ~bar | (disc & bar)
    assert not near(img, BAR, 60)[inside].any()  # no pixel of the bar's colour left in the disc
    rim = disc & ~ndimage.binary_erosion(disc, iterations=2)  # soft edge, arc within a pixel
    assert near(img, DISC, 60)[disc & bar & ~rim].all()  # refilled with the body's colour
    moved = np.roll(bar, 65, axis=0)
    assert near(img, BAR, 30)[moved].mean() > 0.9  # the bar is where it went


@pytest.mark.gl
def test_copy_keeps_the_layer_behind(flat):
    disc, bar = shapes()
    sc = puppet.load_scene(flat)
    before = sc.built.images[0]
    rgba, mask = before.rgba.copy(), before.mask.copy()
    sc.split_layer("body", AROUND_BAR, "bar", cut=False)
    body = sc.built.images[0]
    assert (body.mask == mask).all() and (body.rgba == rgba).all()
    img = swing_bar_away(sc)
    assert near(img, BAR, 30)[bar & ~disc].mean() > 0.95  # today's behaviour: the copy stays behind


def test_split_from_a_mask_equals_from_the_polygon(flat):
    a, b = puppet.load_scene(flat), puppet.load_scene(flat)
    a.split_layer("body", AROUND_BAR, "bar")
    region = np.zeros((H, W), bool)
    region[69:92, 106:189] = True  # the polygon's pixel centres
    b.split_layer("body", region, "bar")
    for x, y in zip(a.built.images, b.built.images):
        assert (x.mask == y.mask).all() and (x.rgba == y.rgba).all()


def test_one_undo_step_and_exact_redo(flat):
    sc = puppet.load_scene(flat)
    doc0, img0 = sc.to_dict(), [im.rgba.copy() for im in sc.built.images]
    n = len(sc.history.undo_stack)
    sc.split_layer("body", AROUND_BAR, "bar")
    doc1, img1 = sc.to_dict(), [im.rgba.copy() for im in sc.built.images]
    assert len(sc.history.undo_stack) == n + 1
    assert sc.history.undo_stack[-1].label == "cut bar from body"
    assert sc.undo()
    assert sc.to_dict() == doc0 and all((a == b.rgba).all() for a, b in zip(img0, sc.built.images))
    assert sc.redo()
    assert sc.to_dict() == doc1 and all((a == b.rgba).all() for a, b in zip(img1, sc.built.images))


def test_save_and_load_round_trip(flat, tmp_path):
    sc = puppet.load_scene(flat)
    sc.split_layer("body", AROUND_BAR, "bar")
    sc.add_pin("grip", "bar", [150, 80])
    out = str(tmp_path / "out" / "cut.json")
    os.makedirs(os.path.dirname(out))
    sc.save(out)
    saved = json.load(open(out))
    assert saved["layers"][0]["inpaint"] == "telea" and "image" not in saved["layers"][0]  # still the source's
    files = [L["mask"]["file"] for L in saved["layers"]]
    assert all(f.startswith("cut.files/") and os.path.exists(os.path.join(tmp_path, "out", f)) for f in files)
    back = puppet.load_scene(out)
    for x, y in zip(sc.built.images, back.built.images):
        assert (x.mask == y.mask).all() and (x.rgba == y.rgba).all()
    assert back.mesh()["layers"] == sc.mesh()["layers"]


def test_pins_on_the_part_go_with_it(flat):
    sc = puppet.load_scene(flat)
    sc.add_pin("tip", "body", [170, 80])
    sc.add_pin("hip", "body", [60, 80])
    sc.split_layer("body", AROUND_BAR, "bar")
    assert {p.name: p.layer for p in sc.data.pins} == {"tip": "bar", "hip": "body"}


@pytest.mark.parametrize("args, message", [
    (("body", [[0, 0], [5, 0], [5, 5], [0, 5]], "bar"), "selects no pixels of layer 'body'"),
    (("body", [[0, 0], [5, 5]], "bar"), "at least 3"),
    (("body", [[0, 0], [5, 5], [7]], "bar"), "at least 3"),
    (("body", "all", "bar"), "at least 3"),
    (("body", [[0, 0], [5, float("nan")], [7, 1]], "bar"), "at least 3"),
    (("body", np.zeros((H, W), bool), "bar"), "selects no pixels"),
    (("body", np.ones((10, 10), bool), "bar"), "canvas's size 200x170"),
    (("body", AROUND_BAR, "body"), "a layer named 'body' exists already"),
    (("legs", AROUND_BAR, "bar"), "no layer named 'legs'"),
    (("body", AROUND_BAR, ""), "split_layer: name must be a non-empty string"),
    (("body", [[0, 0], [W, 0], [W, H], [0, H]], "bar"), "takes all of layer 'body'"),
])
def test_bad_input_is_a_scene_error(flat, args, message):
    sc = puppet.load_scene(flat)
    doc = sc.to_dict()
    with pytest.raises(puppet.SceneError, match=message.replace("(", r"\(").replace(")", r"\)")) as e:
        sc.split_layer(*args)
    assert os.path.basename(flat) in str(e.value)
    assert sc.to_dict() == doc and not sc.history.undo_stack


def transparent_picture():
    """The disc and bar on a transparent background (a layer with its own image)."""
    a = picture()
    a[(a[..., :3] == 255).all(-1), 3] = 0
    return a


@pytest.mark.gl
def test_cut_from_a_layer_with_its_own_image(make_scene):
    disc, bar = shapes()
    off = [7, 4]
    s = {"puppet": 1, "canvas": [W + 10, H + 10], "background": [255, 255, 255, 255],
         "layers": [{"name": "body", "image": "own.png", "offset": off, "inpaint": "pyramid", "order": 3}]}
    sc = puppet.load_scene(make_scene(s, {"own.png": transparent_picture()}))
    poly = [[x + off[0], y + off[1]] for x, y in AROUND_BAR]
    sc.split_layer("body", poly, "bar")
    body, part = sc.to_dict()["layers"]
    assert part["image"].endswith("own.png") and part["offset"] == off and part["order"] == 3
    assert body["image"] != part["image"] and body["offset"] == off
    assert sc.rank == [0, 1]  # the part in front, the same order ties by list position
    sc.add_pin("grip", "bar", [150 + off[0], 80 + off[1]])
    sc.set_target("grip", [150 + off[0], 145 + off[1]])
    img = sc.render()[off[1]:off[1] + H, off[0]:off[0] + W]
    assert (~near(img, WHITE, 12))[bar & ~disc].mean() <= 0.02
    assert not near(img, BAR, 60)[disc].any()


def test_link_segments_on_the_part_go_with_it(make_scene):
    tag = np.zeros((H, W, 4), np.uint8)
    tag[70:90, 160:190] = (10, 200, 10, 255)
    s = {"puppet": 1, "source": "pic.png", "background": [255, 255, 255, 255],
         "layers": [{"name": "body"}, {"name": "tag", "image": "tag.png"}],
         "links": [{"layers": ["body", "tag"], "segments": [[[170, 78], [170, 84]]]}]}
    sc = puppet.load_scene(make_scene(s, {"pic.png": picture(), "tag.png": tag}))
    sc.split_layer("body", AROUND_BAR, "bar")
    assert sc.to_dict()["links"] == [{"layers": ["tag", "bar"], "segments": [[[170, 78], [170, 84]]]}]
    assert [L.name for L in sc.data.layers] == ["body", "bar", "tag"]


def test_cut_flag_must_be_a_bool(flat):
    sc = puppet.load_scene(flat)
    with pytest.raises(puppet.SceneError, match="split_layer: cut must be True or False"):
        sc.split_layer("body", AROUND_BAR, "bar", cut="no")


def test_canvas_to_image_hand_checked():
    from puppet.imaging.masks import canvas_to_image

    c = np.zeros((4, 5), bool)
    c[1, 2] = c[3, 4] = c[0, 0] = True
    out = canvas_to_image(c, (2, 1), (3, 3))  # image pixel (i, j) is canvas (i + 1, j + 2)
    assert out.tolist() == [[True, False, False], [False, False, False], [False, False, True]]
    assert not canvas_to_image(c, (-10, 0), (3, 3)).any()
    assert canvas_to_image(c, (-1, -1), (3, 3)).tolist() == [[False] * 3, [False, True, False], [False] * 3]


def test_cut_from_a_front_source_layer_keeps_the_refill_behind_it(make_scene):
    """Cutting the hand off an arm that is taken from the same picture as the body: the
    body still refills under the arm and under the hand (both are source layers in front)."""
    pic = np.full((100, 160, 4), 255, np.uint8)
    pic[20:80, 20:140, :3] = (40, 160, 60)
    pic[45:55, 30:110, :3] = (200, 30, 30)
    s = {"puppet": 1, "source": "pic.png", "background": [255, 255, 255, 255],
         "layers": [{"name": "body", "mask": {"threshold": 250}, "inpaint": "telea"},
                    {"name": "arm", "mask": {"rect": [30, 45, 80, 10]}}]}
    sc = puppet.load_scene(make_scene(s, {"pic.png": pic}))
    body_before = sc.built.images[0].rgba.copy()
    sc.split_layer("arm", [[28, 43], [50, 43], [50, 57], [28, 57]], "hand")
    assert [L.name for L in sc.data.layers] == ["body", "arm", "hand"]
    assert sc.data.layers[1].image is None and sc.data.layers[2].image is None
    assert (sc.built.images[0].rgba == body_before).all()
    assert not near(sc.built.images[0].rgba, (200, 30, 30), 60)[45:55, 30:110].any()
    arm = sc.built.images[1]
    # the cut end of the arm (a U-turn of its outline) is closed by a half disc of the arm's width
    assert arm.mask[45:55, 50:110].all() and not arm.mask[:, :44].any()
    assert 0 < arm.mask[:, 44:50].sum() <= np.pi * 5 ** 2 / 2 + 6


def square_ring() -> np.ndarray:
    """The pixel outline of an 80 px square, clockwise from its top left corner: (320, 2)."""
    top = [[x, 0] for x in range(80)]
    right = [[80, y] for y in range(80)]
    bottom = [[x, 80] for x in range(80, 0, -1)]
    left = [[0, y] for y in range(80, 0, -1)]
    return np.array(top + right + bottom + left, float)


def test_complete_ring_bridges_a_straight_edge_straight():
    from puppet.imaging.cutout import complete_ring

    P = square_ring()
    cut = np.zeros(len(P), bool)
    cut[35:45] = True  # a notch in the middle of the top edge (the tangent fits stay on the edge)
    R = complete_ring(P, cut)
    assert np.abs(R[(R[:, 0] > 33) & (R[:, 0] < 47) & (R[:, 1] < 5), 1]).max() < 1e-9  # the edge goes on straight
    assert len(R) >= len(P) - 10 and complete_ring(P, np.ones(len(P), bool)) is None
    assert (complete_ring(P, np.zeros(len(P), bool)) == P).all()
    # where the contour starts does not matter (a run across its start included)
    for shift in (-40, -35, 3):
        a = complete_ring(np.roll(P, shift, axis=0), np.roll(cut, shift))
        assert sorted(map(tuple, np.round(a, 9))) == sorted(map(tuple, np.round(R, 9)))


def test_a_cut_the_scene_cannot_take_is_refused_whole(make_scene):
    """The disc has no exterior points once the bar is gone: a pose that moves one makes
    the cut fail, saying so, and nothing changes."""
    s = {"puppet": 1, "source": "pic.png", "layers": [{"name": "body", "exterior": {"auto": True}}],
         "poses": {"p": {"body:ext0": [10, 10]}}}
    sc = puppet.load_scene(make_scene(s, {"pic.png": picture()}))
    doc = sc.to_dict()
    with pytest.raises(puppet.SceneError, match=r"cannot cut 'bar' from 'body': .*'body:ext0' does not exist"):
        sc.split_layer("body", AROUND_BAR, "bar")
    assert sc.to_dict() == doc and not sc.history.undo_stack
