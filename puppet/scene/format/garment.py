"""Compatible extension of scene format v1: ``"garment": {"name", "category", "order"}``
files a scene in a dressing room (``puppet dressroom``, :mod:`puppet.room`). Render,
mesh and animate ignore it; it is validated like every other key."""
from __future__ import annotations

from puppet.scene.format.schema import Ctx, expect_number, expect_object, expect_string, join

#: The categories in drawing order, back to front.
CATEGORIES = ("underwear", "bottom", "top", "dress", "outer", "shoes", "accessory")
DEFAULT_CATEGORY = "top"
#: Largest |order| (orders beyond have no use and would print badly).
MAX_ORDER = 1_000_000


def parse_garment(c: Ctx, v, p: str) -> dict:
    """The validated ``garment`` object: ``{"name"?: str, "category": str, "order": float}``
    (a missing name stays missing: the dressing room uses the file's stem)."""
    expect_object(c, v, p, optional=("name", "category", "order"))
    out = {"category": expect_string(c, v.get("category", DEFAULT_CATEGORY), join(p, "category"),
                                     choices=CATEGORIES),
           "order": expect_number(c, v.get("order", 0), join(p, "order"), lo=-MAX_ORDER, hi=MAX_ORDER)}
    if "name" in v:
        out["name"] = expect_string(c, v["name"], join(p, "name"))
    return out
