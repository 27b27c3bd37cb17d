"""The automatic rig of layered art by anatomy (``puppet init ART --pins auto --links auto``).

A character drawn in layers is a tree of parts: limbs hang off a torso, a hand off its
forearm, and parts painted over another (a sleeve over its arm, a face on its head) move
with it. The largest overlap between two layers says little: a hand drawn in front of a
thigh overlaps it more than its own wrist does. So the rig is found in four steps.

1. **Glue.** A layer whose pixels lie mostly (:data:`COVERED`) inside another's is painted
   on it (a face on a head, an arm under its sleeve): the two are one *unit* and are joined
   by a segment along their overlap, so they bend together.
2. **Contacts.** Two units touch where layers of each overlap (at least :data:`MIN_DEPTH`
   deep). Each contact gets a cost that says how much it looks like a joint: a joint lies
   at an *end* of the child (the contact is far from the child's centroid, measured
   against the child's extent in that direction), and at an end of the parent too unless
   the parent is the root (a torso takes limbs anywhere); a contact in the middle of a part
   is a drawing overlap, not a joint. Names add to it: two limbs of different kinds (a hand
   and a thigh) or of different sides (``left``/``right``, ``_L``/``_R``) cost more, and so
   do two parts in different groups of the file (``legs/left`` against ``arm_right/hand``).
3. **Tree.** Each connected set of units is rooted at its torso: a unit with a torso's name
   (``body``, ``torso``, ``chest``, ...), else the unit that is nearest, in contact hops
   weighted by area, to all the others (the graph's median: a torso touches the most).
   Prim's algorithm grows the tree from the root, cheapest contact first, so a limb joins
   the torso or its own parent limb; a joint becomes a **hinge** (a link point) at the
   centre of the largest disc inside the overlap.
4. **Pins.** The root gets two pins along its long axis (``chest`` and ``hip`` when it
   stands upright), each the deepest pixel of a slab at a quarter and three quarters of
   its length. A unit hinged to the root gets a pin at that hinge (``joint``: a shoulder, a
   hip, a neck) and a unit at the end of a chain a pin at its free end (``end``: the deepest
   pixel of the part's farthest tenth from its joint, measured along the part), so a hand,
   a foot, a head top or a tail tip can be dragged and the limb swings about its shoulder
   or hip. Parts inside a chain (a forearm) get none: pinning them would stop the chain
   from following its end. Silhouette corners never become pins.

Names only weigh the costs; geometry decides alone when the layers are called
``Layer 1``, ``Layer 2``, ... Layers covering nearly the whole canvas (a backdrop) and
hidden ones are left out. All the analysis except the hinge points runs on a copy of the
canvas at most :data:`ANALYSIS` pixels wide, so a 4000 px PSD costs what a 400 px one does.
"""
from __future__ import annotations

import functools
import heapq
import re
from dataclasses import dataclass, field

import numpy as np

from puppet.geom.geodesic import grid_graph
from puppet.imaging.layered import ArtLayer
from puppet.imaging.skeleton import distance_inside
from puppet.scene.make.auto_links import (MIN_DEPTH, Deadline, box_pairs, crop_mask, find_set, join_sets, link_segment,
                                          overlap_box, overlap_count)
from puppet.scene.rig.build import layer_image, load_source

#: The deformer an automatic rig is solved with (when the scene sets none): hinged chains
#: posed from their ends converge slowly, 20 plain iterations leave a knee 3 px off.
RIG_DEFORMER = {"method": "arap", "accelerate": "anderson"}
#: A layer with at least this fraction of its pixels inside another is glued to it.
COVERED = 0.75
#: Longest side of the analysis canvas, pixels.
ANALYSIS = 384
#: Cost of a contact with the root (a part joins a limb's free end before the torso).
AT_ROOT = 0.3
#: Weight of a contact that does not hold the child's whole width.
COVER = 0.5
#: Weight of a distal part (hand, foot) on the root, or a proximal one (upper arm, thigh) off it.
CHAIN_PLACE = 0.5
#: Weight of the parent's own endness at a contact (a wide pelvis takes legs at its corners).
PARENT_END = 0.5
#: Cost of hanging a part from a sibling near their common parent (a trouser leg from the
#: other one at the crotch) when it touches that parent too.
SIBLING = 1.0
#: Name words of parts painted on another (glued to their parent when they end a chain).
PAINTED = {"hair", "fringe", "bangs", "face", "eye", "eyes", "ear", "ears", "mouth", "nose", "brow", "brows", "eyebrow",
           "eyebrows", "beard", "moustache", "mustache", "hat", "cap", "helmet", "glasses", "pocket", "button",
           "buttons", "logo", "badge", "belt", "collar", "tie"}
#: A free end's pin lies where the part is at least this fraction as thick as its thickest.
CORE = 0.4
#: Contacts kept between two units (their layers' largest overlaps), the best one chosen.
PAIRS = 4
#: Largest connected set of units whose tree is improved by local search.
IMPROVE_UNITS = 40
#: Cost of a contact between limbs of different kinds or sides, or parts of different groups.
WRONG_KIND, WRONG_SIDE, OTHER_GROUP = 2.0, 2.0, 0.5

#: Name words and the role they give a part; a role's chain is its first word.
ROLES = {
    "torso": ("torso", "body", "chest", "trunk", "pelvis", "belly", "abdomen", "waist", "hips", "spine",
              "shirt", "tshirt", "blouse", "jacket", "coat", "vest", "dress", "top", "topwear", "bottom",
              "bottomwear", "bra", "bikini", "underwear", "swimsuit", "skirt"),
    "head": ("head", "neck", "face", "skull", "hair", "eye", "eyes", "ear", "ears", "mouth", "nose", "jaw",
             "brow", "eyebrow", "hat", "helmet", "beard", "cap"),
    "arm": ("arm", "arms", "upperarm", "forearm", "sleeve", "elbow", "shoulder", "hand", "hands", "wrist",
            "fist", "finger", "fingers", "thumb", "palm", "glove", "claw"),
    "leg": ("leg", "legs", "thigh", "shin", "calf", "knee", "foot", "feet", "shoe", "shoes", "boot", "boots",
            "toe", "toes", "ankle", "trouser", "trousers", "pants", "sock", "hoof", "paw"),
    "tail": ("tail",),
    "wing": ("wing", "wings"),
}
_WORD_ROLE = {w: role for role, words in ROLES.items() for w in words}
#: Role words that also count inside a compound word (not "ear": handwear, legwear).
_COMPOUND = {w: r for w, r in _WORD_ROLE.items() if len(w) >= 4 or w in ("arm", "leg", "jaw", "toe", "top")}
_LEFT, _RIGHT = {"left", "l", "lft", "lt"}, {"right", "r", "rgt", "rt"}


@functools.lru_cache(maxsize=4096)
def words(name: str) -> tuple[str, ...]:
    """Lower-case words of a layer's path: split at non-letters and at camelCase humps
    (``arm_L/LeftHand`` -> ``arm l left hand``)."""
    spaced = re.sub(r"([a-z])([A-Z])", r"\1 \2", name)
    return tuple(w for w in re.split(r"[^a-zA-Z]+", spaced.lower()) if w)


@functools.lru_cache(maxsize=4096)
def role_of(name: str) -> str | None:
    """The part's role from its path's words, the layer's own name first (its last word
    first: ``body_face`` is a face, ``TopHead`` a head), then its groups' (``legs/left`` is
    a leg); a word ending or starting with a role word counts (``upperarm``, ``handwear``)."""
    for seg in reversed(name.split("/")):
        for w in reversed(words(seg)):  # the last word names the part: body_face is a face
            if w in _WORD_ROLE:
                return _WORD_ROLE[w]
            for test in (str.endswith, str.startswith):  # the end of a compound first: tophead
                for known, role in _COMPOUND.items():
                    if len(w) > len(known) and test(w, known):
                        return role
    return None


@functools.lru_cache(maxsize=4096)
def side_of(name: str) -> str | None:
    """``"left"``, ``"right"`` or None from the path's words (``arm_L``, ``LeftLeg``, ``legs/right``)."""
    ws = words(name)
    left = any(w in _LEFT or w.startswith("left") or w.endswith("left") for w in ws)
    right = any(w in _RIGHT or w.startswith("right") or w.endswith("right") for w in ws)
    return "left" if left and not right else "right" if right and not left else None


@dataclass
class Unit:
    """Layers glued together (indices into the usable layers), their pixels (cell
    centres of the analysis canvas) and their tree links."""
    members: list[int]
    area: float = 0.0  # canvas pixels
    centroid: np.ndarray = field(default_factory=lambda: np.zeros(2))  # canvas (x, y)
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)), repr=False)  # canvas (x, y)
    parent: int | None = None
    hinge: np.ndarray | None = None  # canvas point where it joins its parent
    hinge_layer: int | None = None  # the member in that hinge
    children: list[int] = field(default_factory=list)
    glued: bool = False  # a leaf painted on its parent: joined by a segment, no pins

    def proximal(self, at: np.ndarray, hinge: np.ndarray) -> float:
        """1 at ``hinge``, 0 at the unit's point farthest from it (a limb's free end)."""
        d = np.hypot(*(np.asarray(at, float) - hinge))
        reach = float(np.hypot(*(self.points - hinge).T).max()) if len(self.points) else 0.0
        return float(np.clip(1.0 - d / max(reach, 1e-9), 0.0, 1.0))

    def endness(self, at: np.ndarray) -> float:
        """0 when ``at`` is at the unit's edge seen from its centroid, 1 at its centroid."""
        d = np.asarray(at, float) - self.centroid
        r = float(np.hypot(*d))
        if r < 1e-9 or len(self.points) == 0:
            return 1.0
        reach = float(((self.points - self.centroid) @ (d / r)).max())
        return float(np.clip(1.0 - r / max(reach, 1e-9), 0.0, 1.0))


@dataclass
class Contact:
    """An overlap of a layer of one unit with a layer of another: the two layers, its
    area and its deepest point (:func:`_hinge`), where a hinge would go and where the
    contact is judged."""
    a: int
    b: int
    area: int
    at: np.ndarray
    depth: float  # radius of the largest disc inside the overlap


@dataclass
class Rig:
    """What :func:`propose_rig` found: pins and links in the scene format, and the roots'
    layers (a torso per connected set)."""
    pins: list[dict]
    links: list[dict]
    roots: list[str]


def propose_rig(layers: list[ArtLayer], *, canvas: tuple[int, int], skip=(), deadline: Deadline | None = None) -> Rig:
    """Pins and links for layered art by anatomy (module docstring). ``skip``: frozensets
    of two layer names already linked (they count as glued, get no new link)."""
    W, H = canvas
    late = deadline.passed if deadline is not None else (lambda: False)
    usable = [lay for lay in layers if (lay.bounds[2] - lay.bounds[0]) * (lay.bounds[3] - lay.bounds[1]) < 0.9 * W * H
              and np.count_nonzero(lay.rgba[..., 3]) >= 16]
    n = len(usable)
    index = {lay.name: k for k, lay in enumerate(usable)}
    masks = [lay.rgba[..., 3] > 0 for lay in usable]
    areas = np.array([np.count_nonzero(m) for m in masks], float)
    boxes = [lay.bounds for lay in usable]
    overlaps = []  # (area, i, j)
    for m, (i, j) in enumerate(box_pairs(boxes)):
        if m % 256 == 0 and late():
            break
        area = overlap_count(boxes[i], masks[i], boxes[j], masks[j])
        if area >= 16:
            overlaps.append((area, i, j))
    overlaps.sort(key=lambda t: (-t[0], t[1], t[2]))
    # 1. glue
    root = {k: k for k in range(n)}
    glue = []
    for pair in skip:
        if len(pair) == 2 and pair <= index.keys():
            join_sets(root, *(index[p] for p in pair))
    for area, i, j in overlaps:
        if area >= COVERED * min(areas[i], areas[j]) and join_sets(root, i, j):
            glue.append((i, j))
    members: dict[int, list[int]] = {}
    for k in range(n):
        members.setdefault(find_set(root, k), []).append(k)
    scale = min(1.0, ANALYSIS / max(W, H))
    units = [_unit(ks, usable, scale, (W, H)) for ks in members.values()]
    unit_of = {k: u for u, un in enumerate(units) for k in un.members}
    # 2. contacts between units: the overlaps of their layers (the largest few of each pair)
    contacts: dict[tuple[int, int], list[Contact]] = {}
    for area, i, j in overlaps:
        ui, uj = unit_of[i], unit_of[j]
        key = (min(ui, uj), max(ui, uj))
        if ui == uj or len(contacts.get(key, ())) >= PAIRS or late():
            continue
        hit = _hinge(usable[i], usable[j])
        if hit is not None:
            contacts.setdefault(key, []).append(Contact(i, j, area, hit[0], hit[1]))
    # 3. trees
    roots, chosen = _grow_trees(units, contacts, usable, unit_of, late)
    glue += _glue_leaves(units, chosen, usable)
    links = [_glue_link(usable[i], usable[j]) or _point_link(usable[i], usable[j]) for i, j in glue]
    links = [k for k in links if k is not None]
    for u, un in enumerate(units):
        if un.parent is not None and not un.glued:
            c = chosen[u]
            a, b = sorted((c.a, c.b))
            links.append({"layers": [usable[a].name, usable[b].name],
                          "points": [[round(float(un.hinge[0]), 2), round(float(un.hinge[1]), 2)]]})
    # 4. pins
    pins = []
    for u, un in enumerate(units):
        if late():
            break
        pins += _unit_pins(u, units, usable, masks, areas, root_unit=u in roots)
    taken: set[tuple] = set()  # one pin a point (two on one hinge vertex would be one vertex)
    pins = [p for p in pins if not (tuple(p["at"]) in taken or taken.add(tuple(p["at"])))]
    return Rig(pins, links, [usable[_main(units[u], areas, usable)].name for u in roots])


def rig_scene(scene, *, deadline: Deadline | None = None) -> Rig:
    """The rig :func:`propose_rig` finds for a scene's visible layers (``scene``: a
    :class:`puppet.scene.document.core.Document`), their pixels inside their masks; pins
    only on layers with none, links only between layers not linked yet (those count as
    glued). What the app's "Rig automatically" proposes; ``scene.add_rig`` applies it."""
    data = scene.data
    source = load_source(data)
    layers = []
    for L in data.layers:
        if not L.visible:
            continue
        im = layer_image(data, L, source)
        ys, xs = np.nonzero(im.mask)
        y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
        rgba = im.rgba[y0:y1, x0:x1].copy()
        rgba[..., 3] = np.where(im.mask[y0:y1, x0:x1], np.maximum(rgba[..., 3], 1), 0)
        layers.append(ArtLayer(L.name, rgba, (int(L.offset[0] + x0), int(L.offset[1] + y0))))
    linked = {frozenset(k.layers) for k in data.links}
    pinned = {p.layer for p in data.pins}
    rig = propose_rig(layers, canvas=scene.canvas, skip=linked, deadline=deadline)
    rig.pins = [p for p in rig.pins if p["layer"] not in pinned]
    rig.links = [k for k in rig.links if frozenset(k["layers"]) not in linked]
    return rig


def _unit(ks: list[int], usable: list[ArtLayer], scale: float, canvas) -> Unit:
    """The unit of layers ``ks``: its pixels as cells of the analysis canvas (``scale`` of
    the canvas), each layer's part on the canvas shrunk on its own box."""
    import cv2

    W, H = canvas
    w, h = max(1, round(W * scale)), max(1, round(H * scale))
    cells = []  # row-major cell numbers Y * w + X
    for k in ks:
        lay = usable[k]
        lx, ly = lay.offset
        x0, y0, x1, y1 = lay.bounds
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)  # the part on the canvas
        if x1 <= x0 or y1 <= y0:
            continue
        a = lay.rgba[y0 - ly:y1 - ly, x0 - lx:x1 - lx, 3] > 0
        X0, Y0 = x0, y0
        if scale < 1.0:
            X0, Y0 = int(np.floor(x0 * scale)), int(np.floor(y0 * scale))
            X1, Y1 = max(int(np.ceil(x1 * scale)), X0 + 1), max(int(np.ceil(y1 * scale)), Y0 + 1)
            X1, Y1 = min(X1, w), min(Y1, h)
            if X1 <= X0 or Y1 <= Y0:
                continue
            a = cv2.resize(a.astype(np.float32), (X1 - X0, Y1 - Y0), interpolation=cv2.INTER_AREA) >= 0.5
        ys, xs = np.nonzero(a)
        cells.append((ys + Y0) * w + xs + X0)
    cells = np.unique(np.concatenate(cells)) if cells else np.zeros(0, np.int64)
    if len(cells) == 0:  # a part thinner than an analysis pixel: its box centre
        x0, y0, x1, y1 = usable[ks[0]].bounds
        pts = np.array([[(x0 + x1) / 2, (y0 + y1) / 2]])
    else:
        pts = (np.column_stack([cells % w, cells // w]) + 0.5) / scale
    area = float(sum(np.count_nonzero(usable[k].rgba[..., 3]) for k in ks))
    return Unit(list(ks), area, pts.mean(0), pts)


class _Thickness(dict):
    """Layer index -> the radius of the largest disc inside the layer (computed when asked)."""

    def __init__(self, usable):
        super().__init__()
        self.usable = usable

    def __missing__(self, k: int) -> float:
        self[k] = v = max(float(distance_inside(self.usable[k].rgba[..., 3] > 0).max()), 1.0)
        return v


#: Name words of parts that start a limb (they join the torso) and of parts that end one.
PROXIMAL = ("upperarm", "shoulder", "thigh", "upperleg", "neck", "hips", "pelvis")
DISTAL = ("hand", "hands", "fist", "glove", "finger", "fingers", "thumb", "palm", "claw", "foot", "feet", "shoe",
          "shoes", "boot", "boots", "toe", "toes", "paw", "hoof")


def _names_cost(a: str, b: str, parent_is_root: bool) -> float:
    """What names add to a contact of layer ``a`` (the child) with ``b``: a distal part (a
    hand) on the root or a proximal one (an upper arm) off it, or a part painted on
    another (:data:`PAINTED`: long hair over the shoulders is not the neck),
    :data:`CHAIN_PLACE`; off
    the root, limbs of different kinds (arm and leg), of different sides, or in different
    groups of the file."""
    ws = "".join(words(a.rsplit("/", 1)[-1]))
    cost = CHAIN_PLACE if _painted(a) else 0.0  # hair is no joint
    if parent_is_root and any(ws.endswith(w) for w in DISTAL):
        cost += CHAIN_PLACE
    if not parent_is_root and any(ws.endswith(w) or ws.startswith(w) for w in PROXIMAL):
        cost += CHAIN_PLACE
    if parent_is_root:
        return cost
    ra, rb = role_of(a), role_of(b)
    if ra and rb and ra != rb and "torso" not in (ra, rb):
        cost += WRONG_KIND
    sa, sb = side_of(a), side_of(b)
    if sa and sb and sa != sb:
        cost += WRONG_SIDE
    ga, gb = a.rpartition("/")[0], b.rpartition("/")[0]
    if ga and gb and ga != gb:
        cost += OTHER_GROUP
    return cost


def _choose_root(comp: list[int], units: list[Unit], adj: dict[int, list[int]], usable: list[ArtLayer]) -> int:
    """A torso by name (the largest, when at least a quarter of the largest unit), else the
    area-weighted graph median among the largest and best connected units."""
    biggest = max(units[u].area for u in comp)
    named = [u for u in comp if any(role_of(usable[k].name) == "torso" for k in units[u].members)
             and units[u].area >= 0.25 * biggest]
    if named:
        return max(named, key=lambda u: (units[u].area, -u))
    cands = sorted(comp, key=lambda u: -units[u].area)[:6] + sorted(comp, key=lambda u: -len(adj[u]))[:6]
    best, best_cost = comp[0], np.inf
    for c in dict.fromkeys(cands):
        hops, front, cost = {c: 0}, [c], 0.0
        while front:
            nxt = []
            for u in front:
                for v in adj[u]:
                    if v not in hops:
                        hops[v] = hops[u] + 1
                        cost += units[v].area * hops[v]
                        nxt.append(v)
            front = nxt
        if cost < best_cost - 1e-9 * max(cost, 1.0):
            best, best_cost = c, cost
    return best


def _glue_leaves(units: list[Unit], chosen: dict[int, Contact], usable) -> list[tuple[int, int]]:
    """Leaves of the trees named as things painted on a part (:data:`PAINTED`: hair on a
    head, a pocket on trousers) are glued to their parent, not jointed (the layer pairs to
    join by a segment); they leave its children, and the parent may become a leaf in turn."""
    out, again = [], True
    while again:
        again = False
        for u, un in enumerate(units):
            if un.parent is None or un.glued or un.children:
                continue
            ct = chosen[u]
            if all(_painted(usable[k].name) for k in un.members):
                un.glued, again = True, True
                units[un.parent].children.remove(u)
                out.append((ct.a, ct.b))
    return out


def _grow_trees(units, contacts, usable, unit_of, late) -> tuple[list[int], dict[int, Contact]]:
    """Set each unit's parent, hinge and children; the roots, and the contact each joint
    is at. Per connected set of units: Prim from the root, cheapest contact first, then
    :func:`_improve`."""
    adj: dict[int, list[int]] = {u: [] for u in range(len(units))}
    for (u, v) in contacts:
        adj[u].append(v)
        adj[v].append(u)
    seen, roots, chosen = set(), [], {}
    for start in range(len(units)):
        if start in seen:
            continue
        comp, stack = [], [start]
        seen.add(start)
        while stack:
            u = stack.pop()
            comp.append(u)
            for v in adj[u]:
                if v not in seen:
                    seen.add(v)
                    stack.append(v)
        r = _choose_root(sorted(comp), units, adj, usable)
        roots.append(r)
        costs = _Costs(r, units, contacts, usable, unit_of)
        parent: dict[int, int] = {}
        inside, heap = {r}, []

        def offer(p: int) -> None:
            for c in adj[p]:
                if c not in inside:
                    heapq.heappush(heap, (costs(c, p, parent.get(p)), c, p))
        offer(r)
        while heap:
            _, c, p = heapq.heappop(heap)
            if c not in inside:
                inside.add(c)
                parent[c] = p
                offer(c)
        if len(comp) <= IMPROVE_UNITS and not late():
            parent = _improve(parent, adj, costs)
        for c, p in parent.items():
            ct = chosen[c] = costs.best(c, p)
            un = units[c]
            un.parent, un.hinge = p, ct.at
            un.hinge_layer = ct.a if unit_of[ct.a] == c else ct.b
            units[p].children.append(c)
    return roots, chosen


class _Costs:
    """``costs(c, p, gp)``: how little the contact of unit ``c`` with ``p`` looks like ``c``'s
    joint, ``p`` hanging from ``gp`` (None: ``p`` is the root ``r``): the contact should be
    at ``c``'s end, and at the root (plus :data:`AT_ROOT`) or at ``p``'s free end (far from
    ``p``'s centroid and from its own hinge with ``gp``), and it should hold ``c``'s whole
    width (a shoulder is tucked under the torso, a hand resting on a hip only overlaps it
    at a corner: :data:`COVER` times one less the overlap's inscribed radius over the
    layer's); names add theirs (:func:`_names_cost`). Cached."""

    def __init__(self, r, units, contacts, usable, unit_of):
        self.r, self.units, self.contacts, self.usable, self.unit_of = r, units, contacts, usable, unit_of
        self.memo: dict = {}
        self.thick = _Thickness(usable)

    def local(self, c: int, p: int, ct: Contact) -> float:
        """The terms that depend on the two units and the contact only."""
        key = ("local", c, p, id(ct))
        if key not in self.memo:
            self.memo[key] = self._local(c, p, ct)
        return self.memo[key]

    def _local(self, c: int, p: int, ct: Contact) -> float:
        lc, lp = (ct.a, ct.b) if self.unit_of[ct.a] == c else (ct.b, ct.a)
        cost = self.units[c].endness(ct.at) + COVER * (1.0 - min(1.0, ct.depth / self.thick[lc]))
        cost += AT_ROOT if p == self.r else PARENT_END * self.units[p].endness(ct.at)
        return cost + _names_cost(self.usable[lc].name, self.usable[lp].name, p == self.r)

    def best(self, c: int, p: int) -> Contact:
        """Of the contacts between units ``c`` and ``p``, the one most like ``c``'s joint
        (:meth:`local`): a neck's contact with the torso rather than long hair's."""
        key = ("best", c, p)
        if key not in self.memo:
            found = self.contacts[(min(p, c), max(p, c))]
            self.memo[key] = min(found, key=lambda ct: self.local(c, p, ct))
        return self.memo[key]

    def __call__(self, c: int, p: int, gp: int | None) -> float:
        key = (c, p, gp)
        if key not in self.memo:
            ct = self.best(c, p)
            cost = self.local(c, p, ct)
            if p != self.r:
                near_gp = (min(c, gp), max(c, gp)) in self.contacts
                prox = self.units[p].proximal(ct.at, self.best(p, gp).at)
                cost += prox + (SIBLING if near_gp and prox > 0.5 else 0.0)
            self.memo[key] = cost
        return self.memo[key]

    def total(self, parent: dict[int, int]) -> float:
        return sum(self(c, p, parent.get(p)) for c, p in parent.items())


def _improve(parent: dict[int, int], adj, costs: _Costs, rounds: int = 30) -> dict[int, int]:
    """Local search over the tree: hang a subtree from another of its units (the path from
    that unit to the subtree's top reversed) onto a unit outside it, while the total cost
    falls. Prim commits to the cheapest contact with the torso first, which may be a hand
    resting on the hip; turning the arm's chain round so that it hangs from its shoulder
    costs less in total (the wrist and elbow then join free ends)."""
    best = costs.total(parent)
    for _ in range(rounds):
        kids: dict[int, list[int]] = {}
        for c, p in parent.items():
            kids.setdefault(p, []).append(c)
        move = None
        for top in parent:
            sub, stack = [], [top]
            while stack:
                u = stack.pop()
                sub.append(u)
                stack += kids.get(u, [])
            inside = set(sub)
            for d in sub:
                for q in adj[d]:
                    if q in inside or (d == top and q == parent[top]):
                        continue
                    trial = dict(parent)
                    u, prev = d, q
                    while True:  # reverse the path d -> top
                        nxt = parent.get(u)
                        trial[u] = prev
                        if u == top:
                            break
                        prev, u = u, nxt
                    t = costs.total(trial)
                    if t < best - 1e-9:
                        best, move = t, trial
        if move is None:
            break
        parent = move
    return parent


def _hinge(a: ArtLayer, b: ArtLayer) -> tuple[np.ndarray, float] | None:
    """The centre of the largest disc inside both layers' overlap (ties: the nearest to
    the overlap's centroid among those at least 0.8 as deep), a pixel centre, and that
    disc's radius; None when the overlap is nowhere :data:`MIN_DEPTH` / 2 deep."""
    box = overlap_box(a, b)
    if box is None:
        return None
    both = crop_mask(a, box) & crop_mask(b, box)
    depth = distance_inside(both)
    top = float(depth.max())
    if top < MIN_DEPTH / 2:
        return None
    ys, xs = np.nonzero(depth >= 0.8 * top)
    cy, cx = np.nonzero(both)
    i = int(np.argmin((xs - cx.mean()) ** 2 + (ys - cy.mean()) ** 2))
    return np.array([xs[i] + box[0] + 0.5, ys[i] + box[1] + 0.5]), top


def _glue_link(a: ArtLayer, b: ArtLayer) -> dict | None:
    """A segment along the overlap of a layer painted on another (its principal axis through
    its centroid, the run inside the overlap, ends pulled in by a tenth), so they bend
    together; the short crossing segment of :func:`link_segment` when the overlap is too short."""
    box = overlap_box(a, b)
    if box is None:
        return None
    both = crop_mask(a, box) & crop_mask(b, box)
    ys, xs = np.nonzero(both)
    if len(xs) < 16:
        return None
    P = np.column_stack([xs, ys]) + 0.5
    c = P.mean(0)
    _, vecs = np.linalg.eigh(np.cov((P - c).T))
    axis = vecs[:, -1]
    t = np.arange(-max(both.shape), max(both.shape) + 0.5, 0.5)
    Q = c + t[:, None] * axis
    qi, qj = np.floor(Q[:, 1]).astype(int), np.floor(Q[:, 0]).astype(int)
    ok = (qi >= 0) & (qi < both.shape[0]) & (qj >= 0) & (qj < both.shape[1])
    inside = np.zeros(len(t), bool)
    inside[ok] = both[qi[ok], qj[ok]]
    mid = int(np.argmin(np.abs(t)))
    if not inside[mid]:
        hit = link_segment(a, b)
        return None if hit is None else {"layers": [a.name, b.name], "segments": [hit[0]]}
    lo = hi = mid
    while lo > 0 and inside[lo - 1]:
        lo -= 1
    while hi < len(t) - 1 and inside[hi + 1]:
        hi += 1
    span = t[hi] - t[lo]
    pull = max(2.0, 0.1 * span)
    if span - 2 * pull < 4.0:
        hit = link_segment(a, b)
        return None if hit is None else {"layers": [a.name, b.name], "segments": [hit[0]]}
    p, q = Q[lo] + pull * axis + box[:2], Q[hi] - pull * axis + box[:2]
    seg = [[round(float(p[0]), 2), round(float(p[1]), 2)], [round(float(q[0]), 2), round(float(q[1]), 2)]]
    return {"layers": [a.name, b.name], "segments": [seg]}


def _point_link(a: ArtLayer, b: ArtLayer) -> dict | None:
    """A hinge at the deepest point of two glued layers' overlap, where no segment fits in
    it (so the two stay one group), or None."""
    hit = _hinge(a, b)
    if hit is None:
        return None
    return {"layers": [a.name, b.name], "points": [[round(float(hit[0][0]), 2), round(float(hit[0][1]), 2)]]}


def _main(un: Unit, areas: np.ndarray, usable) -> int:
    """The unit's largest layer not named as painted on (:data:`PAINTED`, a face aside: the
    face rather than the long hair behind it): its pins go there."""
    plain = [k for k in un.members if not _painted(usable[k].name, PAINTED - {"face"})] or un.members
    return max(plain, key=lambda k: (areas[k], -k))


def _painted(name: str, kinds=None) -> bool:
    """The layer's own name says it is painted on another (``kinds``: these words only)."""
    return any(w in (PAINTED if kinds is None else kinds) for w in words(name.rsplit("/", 1)[-1]))


def _unit_pins(u: int, units: list[Unit], usable, masks, areas, *, root_unit: bool) -> list[dict]:
    un = units[u]
    out = []
    if un.glued:
        return out
    if root_unit:
        k = _main(un, areas, usable)
        for name, at in _axis_pins(masks[k]):
            out.append(_pin(usable[k], name, at))
        return out
    if units[un.parent].parent is None:  # hinged to the root: a shoulder, a hip, a neck
        out.append(_pin(usable[un.hinge_layer], "joint", un.hinge - usable[un.hinge_layer].offset))
    if not un.children:
        k = _main(un, areas, usable)
        end = _free_end(masks[k], un.hinge - usable[k].offset)
        if end is not None:
            out.append(_pin(usable[k], "end", end))
    return out


def _pin(lay: ArtLayer, name: str, at) -> dict:
    ox, oy = lay.offset
    return {"name": f"{lay.name}:{name}", "layer": lay.name,
            "at": [round(float(at[0]) + ox, 2), round(float(at[1]) + oy, 2)]}


def _small(mask: np.ndarray, side: int = 128) -> tuple[np.ndarray, float]:
    import cv2

    h, w = mask.shape
    s = min(1.0, side / max(h, w))
    if s >= 1.0:
        return mask, 1.0
    size = (max(1, round(w * s)), max(1, round(h * s)))
    return cv2.resize(mask.astype(np.float32), size, interpolation=cv2.INTER_AREA) >= 0.5, s


def _axis_pins(mask: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """Two pins along the mask's long axis, in the slabs from 15 to 35 % and from 65 to 85 %
    of its length: of each slab's pixels at least 0.7 as deep as its deepest, the one nearest
    the slab's centroid (``chest``/``hip`` upright, else ``front``/``back``);
    one (``centre``) for a part too small to hold two apart."""
    depth = distance_inside(mask)
    ys, xs = np.nonzero(mask)
    P = np.column_stack([xs, ys]) + 0.5
    c = P.mean(0)
    if len(P) < 3:
        return [("centre", c)]
    _, vecs = np.linalg.eigh(np.cov((P - c).T))
    axis = vecs[:, -1]
    if abs(axis[1]) >= abs(axis[0]):
        axis = axis if axis[1] > 0 else -axis  # first: the top
        names = ("chest", "hip")
    else:
        axis = axis if axis[0] > 0 else -axis
        names = ("front", "back")
    t = (P - c) @ axis
    lo, hi = t.min(), t.max()
    d = depth[ys, xs]
    out = []
    for name, (a, b) in zip(names, ((0.15, 0.35), (0.65, 0.85))):
        sel = np.flatnonzero((t >= lo + a * (hi - lo)) & (t <= lo + b * (hi - lo)))
        if len(sel):
            deep = sel[d[sel] >= 0.7 * d[sel].max()]  # deep enough, then the nearest the slab's middle
            mid = P[sel].mean(0)
            out.append((name, P[deep[int(np.argmin(((P[deep] - mid) ** 2).sum(1)))]]))
    if len(out) < 2 or np.hypot(*(out[0][1] - out[1][1])) < 4.0:
        i = int(np.argmax(d))
        return [("centre", P[i])]
    return out


def _free_end(mask: np.ndarray, joint: np.ndarray) -> np.ndarray | None:
    """The free end of a part joined at ``joint``: of its core (pixels at least
    :data:`CORE` as deep as its deepest, so never a silhouette corner), the pixels farthest
    from the joint (within one step), distances measured inside the part (8-neighbour steps
    on a copy at most 128 px wide); the one nearest their centroid. On a limb that is the
    middle of its end cap, on a square hand the inside of its far corner."""
    import cv2
    from scipy.sparse.csgraph import dijkstra

    small, s = _small(mask)
    h, w = small.shape
    ys, xs = np.nonzero(small)
    if len(xs) == 0:
        return None
    _, G = grid_graph(small)
    j = np.asarray(joint, float) * s
    src = int(np.argmin((xs + 0.5 - j[0]) ** 2 + (ys + 0.5 - j[1]) ** 2))
    dist = np.full((h, w), -1.0)
    dist[ys, xs] = dijkstra(G, directed=False, indices=src)
    dist[~np.isfinite(dist)] = -1.0
    if s < 1.0:  # each layer pixel takes its small pixel's distance
        dist = cv2.resize(dist, (mask.shape[1], mask.shape[0]), interpolation=cv2.INTER_NEAREST)
    depth = distance_inside(mask)
    cy, cx = np.nonzero(mask & (depth >= CORE * depth.max()))
    if len(cx) == 0:
        return None
    d = dist[cy, cx]
    if d.max() <= 0:
        return None
    far = np.flatnonzero(d >= d.max() - 1.5)
    i = far[int(np.argmin((cx[far] - cx[far].mean()) ** 2 + (cy[far] - cy[far].mean()) ** 2))]
    return np.array([cx[i] + 0.5, cy[i] + 0.5])
