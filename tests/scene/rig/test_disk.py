"""The disk cache beside a scene (``.puppet-cache/``, puppet.scene.rig.disk): a second
open reads the built parts instead of building them, with results bit-identical to a
build without it; every input a part depends on gives another entry; a corrupt, stale,
swapped, hostile or linked entry is ignored and rebuilt; a read-only folder only skips
writing."""
from __future__ import annotations

import io
import json
import os
import zipfile

import numpy as np
import pytest

from puppet.scene.document.core import Document
from puppet.scene.rig import disk
from tests.conftest import bar_image, write_rgba
from tests.scene.document.test_edits import three_bars

POSE = {"a2": [100, 8], "c1": [150, 58], "b1": [20, 75]}


@pytest.fixture
def cached(monkeypatch):
    monkeypatch.setenv(disk.ENV, "on")


def scene(make_scene, change=None, images=None) -> str:
    s = three_bars()
    s["layers"][1]["mask"] = {"file": "mask.png"}
    s["layers"][2]["stiffness"] = {"file": "stiff.png"}
    if change:
        change(s)
    mask = np.zeros((40, 120), np.uint8)
    mask[12:28, 5:115] = 255
    stiff = np.zeros((40, 120, 4), np.uint8)
    stiff[10:30, 40:80] = (128, 128, 128, 255)
    files = {"bar.png": bar_image(), "stiff.png": stiff}
    files.update(images or {})
    path = make_scene(s, files)
    from PIL import Image
    Image.fromarray(mask).save(os.path.join(os.path.dirname(path), "mask.png"))
    return path


#: what each open of :func:`results` did, for assertion messages (an entry rebuilt when it
#: should have been read was seen twice in full suites and never alone: say why next time)
OPENS: list[str] = []


def results(path: str):
    """(layers of a pose, built counts, disk loads) of a fresh load (a new process' view)."""
    doc = Document.load(path)
    out = doc.layers(POSE)
    disk.flush()
    store = doc.rig.memo.disk
    if store is not None:
        OPENS.append(f"builds {dict(doc.rig.memo.builds)} loads {store.loads} saves {store.saves} "
                     f"rejects {store.rejects} {store.why}; entries {_listing(path)}")
    return out, dict(doc.rig.memo.builds), dict(store.loads) if store else {}


def _listing(path) -> list:
    f = os.path.join(os.path.dirname(path), disk.FOLDER)
    return sorted((n[:14], os.path.getsize(os.path.join(f, n))) for n in os.listdir(f)) if os.path.isdir(f) else []


def opens() -> str:
    """The last three opens, for an assertion message."""
    return "\n".join(OPENS[-3:])


def same(x, y):
    assert len(x) == len(y)
    for r, s in zip(x, y):
        for a in ("rest", "deformed", "triangles", "depth"):
            assert np.array_equal(getattr(r, a), getattr(s, a)), (r.name, a)


def cold(path, monkeypatch):
    monkeypatch.setenv(disk.ENV, "off")
    out = results(path)[0]
    monkeypatch.setenv(disk.ENV, "on")
    return out


def folder(path):
    return os.path.join(os.path.dirname(path), disk.FOLDER)


def test_a_second_open_builds_nothing_and_equals_a_build_without_cache(make_scene, cached, monkeypatch):
    path = scene(make_scene)
    reference = cold(path, monkeypatch)
    assert not os.path.exists(folder(path))  # PUPPET_CACHE=off writes nothing
    first, builds, loads = results(path)
    assert builds["precompute"] == 2 and not loads
    second, builds, loads = results(path)
    assert not any(builds.get(k) for k in disk.KINDS), opens()
    assert loads["mesh"] == 3 and loads["precompute"] == 2 and loads["image"] == 3
    assert loads["pose"] == 2  # the pose shown, one per group: not solved again
    same(first, reference)
    same(second, reference)


INPUTS = {
    "mesh options": (lambda s: s["layers"][0].update(mesh={"max_area": 40}), "mesh"),
    "a link": (lambda s: s["links"][0].update(segments=[[[80, 68], [100, 68]]]), "mesh"),
    "a pin": (lambda s: s["pins"][0].update(at=[17, 20]), "mesh"),
    "the deformer": (lambda s: s.update(deformer={"weights": "uniform"}), "precompute"),
    "the mode": (lambda s: s.update(deformer={"mode": "similar"}), "precompute"),
}


@pytest.mark.parametrize("name", list(INPUTS))
def test_each_scene_input_gives_new_entries(make_scene, cached, monkeypatch, name):
    change, kind = INPUTS[name]
    path = scene(make_scene)
    results(path)
    path = scene(make_scene, change)
    out, builds, _ = results(path)
    assert builds.get(kind, 0) >= 1
    same(out, cold(path, monkeypatch))


def _stored_png(path: str, a: np.ndarray) -> None:
    """A PNG without compression: its size depends only on the image's shape and mode."""
    from PIL import Image
    Image.fromarray(a).save(path, compress_level=0)


@pytest.mark.parametrize("file, kind", [("bar.png", "image"), ("mask.png", "image"), ("stiff.png", "precompute")])
def test_new_file_bytes_with_the_same_size_and_mtime_are_seen(make_scene, cached, monkeypatch, file, kind):
    from PIL import Image
    path = scene(make_scene)
    target = os.path.join(os.path.dirname(path), file)
    a = np.asarray(Image.open(target)).copy()
    _stored_png(target, a)
    results(path)
    st = os.stat(target)
    if a.ndim == 2:  # the mask: a smaller one
        a[:, 100:] = 0
    else:  # other colours, or another grey
        a[15:25, 50:70, :3] = 255 - a[15:25, 50:70, :3]
        a[15:25, 50:70, 3] = 255
    _stored_png(target, a)
    os.utime(target, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert os.path.getsize(target) == st.st_size and os.stat(target).st_mtime_ns == st.st_mtime_ns
    out, builds, _ = results(path)
    assert builds.get(kind, 0) >= 1
    same(out, cold(path, monkeypatch))


def test_a_new_code_version_gives_new_entries(make_scene, cached, monkeypatch):
    path = scene(make_scene)
    results(path)
    monkeypatch.setattr(disk, "CODE_VERSION", disk.CODE_VERSION + 1)
    _, builds, loads = results(path)
    assert builds["mesh"] == 3 and builds["precompute"] == 2 and not loads


def _entries(path, kind="precompute"):
    f = folder(path)
    return sorted(os.path.join(f, n) for n in os.listdir(f) if n.startswith(kind + "-" if kind else ""))


def _npz(arrays: dict) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _members(entry: str) -> dict:
    with np.load(entry, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _spoil_nan(entry):
    m = _members(entry)
    name = next(k for k, a in m.items() if a.dtype == np.float64 and a.size)
    m[name] = m[name].copy()
    m[name].flat[0] = np.nan
    open(entry, "wb").write(_npz(m))


def _spoil_dtype(entry):
    m = _members(entry)
    name = next(k for k, a in m.items() if a.dtype == np.float64 and a.size)
    m[name] = m[name].astype(np.float32)
    open(entry, "wb").write(_npz(m))


def _spoil_index(entry):
    m = _members(entry)
    meta = json.loads(m["meta"].tobytes())
    text = json.dumps(meta)
    name = next(k for k, a in m.items() if a.dtype.kind == "i" and a.ndim == 2 and a.shape[1] == 3)  # triangles
    assert name in text
    m[name] = m[name].copy()
    m[name][0, 0] = 10 ** 6
    open(entry, "wb").write(_npz(m))


def _spoil_huge(entry):
    """A member whose header claims a terabyte."""
    m = _members(entry)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for k, a in m.items():
            data = io.BytesIO()
            np.lib.format.write_array(data, a)
            raw = data.getvalue()
            if a.dtype == np.float64 and a.ndim == 2 and k != "meta":
                header = io.BytesIO()
                np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False,
                                                              "shape": (1 << 37,)})
                raw = header.getvalue() + a.tobytes()
            z.writestr(k + ".npy", raw)
    open(entry, "wb").write(buf.getvalue())


SPOILS = {
    "random bytes": lambda e: open(e, "wb").write(os.urandom(2000)),
    "truncated": lambda e: open(e, "r+b").truncate(os.path.getsize(e) // 2),
    "empty": lambda e: open(e, "wb").close(),
    "NaN": _spoil_nan,
    "wrong dtype": _spoil_dtype,
    "index out of the mesh": _spoil_index,
    "huge shape": _spoil_huge,
    "pickle": lambda e: open(e, "wb").write(__import__("pickle").dumps({"meta": 1})),
}


@pytest.mark.parametrize("kind, name", [(k, n) for k in ("precompute", "mesh", "groups", "pose") for n in SPOILS
                                        if (k, n) != ("pose", "index out of the mesh")])  # a pose has no indices
def test_a_spoiled_entry_is_ignored_rebuilt_and_written_again(make_scene, cached, monkeypatch, name, kind):
    path = scene(make_scene)
    reference = results(path)[0]
    for entry in _entries(path, kind):
        SPOILS[name](entry)
    out, builds, _ = results(path)
    assert builds.get(kind, 0) >= 1
    same(out, reference)
    out, builds, loads = results(path)  # written again, good now
    assert not builds.get(kind) and loads[kind] >= 1, opens()
    same(out, reference)


def test_a_swapped_entry_is_refused(make_scene, cached):
    path = scene(make_scene)
    reference = results(path)[0]
    a, b = _entries(path, "mesh")[:2]
    data_a, data_b = open(a, "rb").read(), open(b, "rb").read()
    open(a, "wb").write(data_b)
    open(b, "wb").write(data_a)
    out, builds, _ = results(path)
    assert builds["mesh"] >= 2
    same(out, reference)


def test_linked_entries_and_folders_are_neither_read_nor_written(make_scene, cached, tmp_path):
    path = scene(make_scene)
    reference = results(path)[0]
    f = folder(path)
    # a link in place of an entry: not followed (rebuilt), and the file it names untouched
    entry = _entries(path, "precompute")[0]
    elsewhere = tmp_path / "elsewhere.npz"
    os.replace(entry, elsewhere)
    os.symlink(elsewhere, entry)
    before = elsewhere.read_bytes()
    out, builds, _ = results(path)
    assert builds["precompute"] >= 1
    assert os.path.islink(entry) and elsewhere.read_bytes() == before
    same(out, reference)
    # the folder itself a link: nothing read, nothing written through it
    real = tmp_path / "real-cache"
    os.rename(f, real)
    os.symlink(real, f)
    names = sorted(os.listdir(real))
    out, builds, loads = results(path)
    assert builds["mesh"] == 3 and builds["precompute"] == 2 and not loads
    assert sorted(os.listdir(real)) == names
    same(out, reference)


def test_a_read_only_folder_works_without_writing(make_scene, cached, monkeypatch):
    path = scene(make_scene)
    reference = cold(path, monkeypatch)
    here = os.path.dirname(path)
    if os.geteuid() == 0:  # root writes into read-only folders: a read-only file system then

        def refused(*a, **k):
            raise OSError(30, "Read-only file system")

        monkeypatch.setattr(disk.os, "mkdir", refused)
    os.chmod(here, 0o555)
    try:
        out, builds, _ = results(path)
    finally:
        os.chmod(here, 0o755)
    assert not os.path.exists(folder(path)) and builds["mesh"] == 3
    same(out, reference)


def test_an_unwritable_cache_folder_only_skips_writing(make_scene, cached, monkeypatch):
    path = scene(make_scene)
    reference = cold(path, monkeypatch)
    open(folder(path), "w").close()  # a file where the folder would be: cannot be made
    out, builds, loads = results(path)
    assert builds["mesh"] == 3 and not loads
    same(out, reference)


def test_the_size_bound_drops_the_oldest_entries(make_scene, cached, monkeypatch):
    path = scene(make_scene)
    results(path)
    sizes = [os.path.getsize(e) for e in _entries(path, "")]
    monkeypatch.setattr(disk, "MAX_BYTES", max(sizes) * 2)
    monkeypatch.setattr(disk, "CODE_VERSION", disk.CODE_VERSION + 1)
    results(path)
    assert sum(os.path.getsize(e) for e in _entries(path, "")) <= max(sizes) * 2


def test_a_part_holding_an_unknown_type_is_not_stored(tmp_path):
    store = disk.DiskStore(str(tmp_path / "c"))
    assert not store.save("mesh", "k", {"f": lambda: 1})
    assert not store.save("mesh", "k", np.array([object()]))
    assert store.load("mesh", "k") is None
    assert store.save("mesh", "k", {"a": np.arange(3), "t": (1, 2.5, "x"), "n": None})
    back = store.load("mesh", "k")
    assert np.array_equal(back["a"], np.arange(3)) and back["t"] == (1, 2.5, "x") and back["n"] is None


def test_layers_built_on_threads_equal_layers_built_one_by_one(make_scene, monkeypatch):
    from puppet.scene.rig import core
    path = scene(make_scene)
    threaded = results(path)[0]
    monkeypatch.setattr(core, "WORKERS", 1)
    same(results(path)[0], threaded)


def test_a_layer_error_on_a_thread_is_the_first_in_layer_order(make_scene, monkeypatch):
    from puppet.errors import SceneError

    def broken(s):
        s["pins"][0]["at"] = [1, 1]  # outside layer a's mask
        s["pins"][2]["at"] = [1, 51]  # outside layer b's mask
    path = scene(make_scene, broken)
    with pytest.raises(SceneError, match=r"pins\[0\]"):
        Document.load(path).built


def test_a_compressed_or_incomplete_entry_is_refused(tmp_path):
    from puppet.scene.rig.build import Group
    from puppet.geom.merge import GroupMesh
    store = disk.DiskStore(str(tmp_path / "c"))
    g = Group(layers=[0], mesh=GroupMesh(V=np.zeros((3, 2)), F=np.array([[0, 1, 2]]), maps=[np.arange(3)]))
    assert store.save("groups", "k", [g])
    assert store.load("groups", "k")[0].layers == [0]
    entry = _entries_in(store.folder)[0]
    m = _members(entry)
    buf = io.BytesIO()
    np.savez_compressed(buf, **m)
    open(entry, "wb").write(buf.getvalue())
    assert store.load("groups", "k") is None
    meta = json.loads(m["meta"].tobytes())
    good = json.loads(json.dumps(meta))
    del meta["tree"]["list"][0]["fields"]["b"]  # a Group without its pinned vertices
    m["meta"] = np.frombuffer(json.dumps(meta).encode(), np.uint8)
    open(entry, "wb").write(_npz(m))
    assert store.load("groups", "k") is None
    b = good["tree"]["list"][0]["fields"]["b"]["nd"]  # pinned vertices outside the group's mesh
    m["meta"] = np.frombuffer(json.dumps(good).encode(), np.uint8)
    m[b] = np.array([7], np.int64)
    good["tree"]["list"][0]["fields"]["b"]["shape"] = [1]
    m["meta"] = np.frombuffer(json.dumps(good).encode(), np.uint8)
    open(entry, "wb").write(_npz(m))
    assert store.load("groups", "k") is None
    assert store.rejects["groups"] == 3


def _entries_in(f):
    return sorted(os.path.join(f, n) for n in os.listdir(f))


def test_a_changed_source_file_gives_new_entries(make_scene, cached, monkeypatch):
    path = scene(make_scene)
    results(path)
    monkeypatch.setattr(disk, "BUILDERS", disk.BUILDERS + ("render",))  # as if another file changed
    disk._code_stamp.cache_clear()
    try:
        _, builds, loads = results(path)
    finally:
        disk._code_stamp.cache_clear()
    assert builds["mesh"] == 3 and not loads


def test_a_factor_read_from_disk_is_made_again_and_takes_its_place(make_scene, cached):
    path = scene(make_scene)
    results(path)
    doc = Document.load(path)
    pre = doc.built.pre[1]  # the linked group
    fresh = Document(doc.to_dict(), path).built.pre[1].arap.factor  # built here, no disk
    f = pre.arap.factor
    rhs = np.linspace(0.0, 1.0, f.n)  # waits for the factor
    assert np.array_equal(f.solve(rhs), fresh.solve(rhs))
    assert type(pre.arap.factor) is type(fresh)  # the factor itself now, not its stand-in


def test_a_command_writes_every_entry_before_it_exits(make_scene, cached, tmp_path):
    import subprocess
    import sys
    path = scene(make_scene)
    env = dict(os.environ, PUPPET_CACHE="on")
    subprocess.run([sys.executable, "-m", "puppet", "mesh", path, "-o", str(tmp_path / "m.json")], env=env,
                   check=True, capture_output=True)
    assert not [n for n in os.listdir(folder(path)) if n.endswith(".tmp")]
    _, builds, loads = results(path)
    # every part but the pose: the command showed the scene's own pose, results() another
    assert not any(builds.get(k) for k in disk.KINDS if k != "pose"), builds


def test_a_command_from_the_cache_ends_cleanly_while_its_factor_is_made_again(make_scene, cached, tmp_path):
    """A second `puppet mesh` reads the precomputation, whose factor is made again on a
    thread, and may end before that thread: the interpreter waits for it (a daemon thread
    inside QDLDL at exit aborted the process: "terminate called without an active
    exception", exit status -6)."""
    import subprocess
    import sys

    from tests.batch.conftest import copy_scene
    path = copy_scene("trex-layers.json", tmp_path)  # 7.7k vertices: its factor takes a while
    env = dict(os.environ, PUPPET_CACHE="on")
    for _ in range(3):
        p = subprocess.run([sys.executable, "-m", "puppet", "mesh", path, "-o", str(tmp_path / "m.json")], env=env,
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 0 and "terminate" not in p.stderr, (p.returncode, p.stderr[-500:])


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork here")
def test_a_forked_child_writes_with_a_writer_of_its_own(tmp_path):
    store = disk.DiskStore(str(tmp_path / "c"))
    store.save_later("mesh", "parent", {"a": np.arange(3)})
    disk.flush()
    pid = os.fork()
    if pid == 0:  # the child: queue, write, exit through the normal path
        code = 1
        try:
            store.save_later("mesh", "child", {"a": np.arange(4)})
            disk.flush()
            code = 0 if store.load("mesh", "child") is not None else 1
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    assert np.array_equal(store.load("mesh", "child")["a"], np.arange(4))


@pytest.mark.gl
def test_a_render_from_the_cache_equals_one_without(make_scene, cached, monkeypatch):
    import puppet
    path = scene(make_scene)

    def render():
        s = puppet.load_scene(path)
        try:
            return s.render(POSE)
        finally:
            s.close()
            disk.flush()

    monkeypatch.setenv(disk.ENV, "off")
    reference = render()
    monkeypatch.setenv(disk.ENV, "on")
    first, second = render(), render()
    assert np.array_equal(first, reference) and np.array_equal(second, reference)


def test_only_the_first_pose_of_a_group_version_is_kept_on_disk(make_scene, cached, monkeypatch):
    """The pose a scene opens with is kept (one entry per group); the poses solved after it in
    the same process (drags, animation frames) are not written, nor is a warm-started solve."""
    path = scene(make_scene)
    doc = Document.load(path)
    doc.layers(POSE)
    disk.flush()
    kept = _entries(path, "pose")
    assert len(kept) == 2
    doc.layers({**POSE, "a2": [104, 10]})
    warm = Document.load(path)  # a first solve, warm-started: not kept either
    starts = {gi: g.mesh.V.astype(float) for gi, g in enumerate(warm.built.groups)}
    with warm.rig.warm_started(warm.built, starts):
        warm.layers({**POSE, "c1": [152, 60]})
    disk.flush()
    assert _entries(path, "pose") == kept
    again = Document.load(path)
    out = again.layers(POSE)
    assert not again.rig.memo.builds.get("pose") and again.rig.memo.disk.loads["pose"] == 2
    same(out, cold(path, monkeypatch))


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads VmPeak from /proc")
def test_reading_an_entry_reserves_its_size_not_the_folder_bound(tmp_path):
    """An entry is read with one read of its size: a read of the folder's bound (1 GiB)
    reserved that much address space for every entry read (VmPeak up by 1 GiB)."""
    import subprocess
    import sys
    code = f"""if True:
        import numpy as np
        from puppet.scene.rig import disk
        def peak():
            return int([l for l in open("/proc/self/status") if l.startswith("VmPeak")][0].split()[1])
        store = disk.DiskStore({str(tmp_path / "c")!r})
        assert store.save("mesh", "k", {{"a": np.arange(1000)}})
        before = peak()
        assert store.load("mesh", "k") is not None
        print(peak() - before)"""
    grown = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert int(grown) < 256 * 1024, f"{grown} KiB more address space"
