"""Layer file names (issue 30, 8): bounded, unique case-insensitively, stable."""
from __future__ import annotations

from puppet.scene.make.art import MAX_FILE_NAME, file_stem, safe_stem


def test_short_names_read_as_they_are():
    assert safe_stem("legs/left") == "legs__left"
    assert safe_stem("arm front!") == "arm_front"
    assert safe_stem("...") == "layer"


def test_long_names_are_cut_with_a_hash_of_the_whole_name():
    names = ["a" * 255, "a" * 254 + "b", "é" * 5000, "/".join(["g"] * 200) + "/leaf"]
    taken: set[str] = set()
    stems = [file_stem(n, taken) for n in names]
    assert all(len((s + ".png").encode()) <= MAX_FILE_NAME for s in stems)
    assert len({s.lower() for s in stems}) == 4
    assert [file_stem(n, set()) for n in names[:2]] == stems[:2]  # the same name, the same stem


def test_names_unique_case_insensitively_and_bounded_after_a_clash():
    taken: set[str] = set()
    a, b, c = file_stem("Arm", taken), file_stem("arm", taken), file_stem("a" * 300, taken)
    assert a == "Arm" and b.lower() != "arm" and b.startswith("arm-")
    d = file_stem("a" * 300, taken)  # the same long name twice
    assert d.lower() != c.lower() and len((d + ".png").encode()) <= MAX_FILE_NAME
