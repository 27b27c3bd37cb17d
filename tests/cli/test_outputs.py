"""Nothing a user types destroys a file: outputs that are inputs, unwritable outputs,
frame folders from earlier runs, and signals, all through the real ``python -m puppet``.

Every case checks: the exit status, exactly one stderr line and no traceback, every
input byte-identical afterwards, and no file or temporary left (folder listings equal).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from tests.cli.outputs_helpers import Mount, cli, make_bar, one_error_line, snapshot

pytestmark = pytest.mark.gl

INPUT_NAMES = ["scene.json", "bar.png", "mask.png", "source.png", "bg.png"]


@pytest.fixture
def scene(tmp_path):
    """A scene reading every kind of input: scene file, layer image, mask file, source, background."""
    return make_bar(tmp_path / "s", mask=True, source=True, background=True)


# -- 1. outputs that are inputs -------------------------------------------------------
@pytest.mark.parametrize("command,name", [
    ("mesh", "scene.json"), ("render", "bar.png"), ("render", "mask.png"), ("render", "source.png"),
    ("render", "bg.png")])
def test_output_that_is_an_input_is_refused(scene, command, name):
    folder = os.path.dirname(scene)
    out = os.path.join(folder, name)
    before = snapshot(folder)
    line = one_error_line(cli(command, scene, "-o", out))
    assert f"{out}: cannot write:" in line and "the scene reads" in line
    assert os.path.realpath(out) in line  # names both paths (the output and the input)
    assert snapshot(folder) == before


def test_render_onto_its_own_scene_json_extension_is_a_usage_error(scene):
    folder = os.path.dirname(scene)
    before = snapshot(folder)
    line = one_error_line(cli("render", scene, "-o", scene))
    assert "must end in .png" in line
    assert snapshot(folder) == before


@pytest.mark.parametrize("target", ["bar.png", "mask.png", "scene.json"])
def test_symlink_or_hard_link_to_an_input_is_refused(scene, tmp_path, target):
    folder = os.path.dirname(scene)
    ext = os.path.splitext(target)[1]
    command = "mesh" if ext == ".json" else "render"
    os.symlink(os.path.join(folder, target), tmp_path / f"link{ext}")
    os.link(os.path.join(folder, target), tmp_path / f"hard{ext}")
    before = snapshot(tmp_path)
    for name in (f"link{ext}", f"hard{ext}"):
        out = tmp_path / name
        line = one_error_line(cli(command, scene, "-o", out))
        assert f"{out}: cannot write: it is a file the scene reads: '{os.path.join(folder, target)}'" in line
    assert snapshot(tmp_path) == before


def test_symlinked_output_is_written_through(scene, tmp_path):
    """A symlink to an ordinary file stays a symlink; its target gets the new image."""
    (tmp_path / "real.png").write_bytes(b"old")
    os.symlink(tmp_path / "real.png", tmp_path / "o.png")
    r = cli("render", scene, "-o", tmp_path / "o.png")
    assert r.returncode == 0, r.stderr
    assert os.path.islink(tmp_path / "o.png")
    assert (tmp_path / "real.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("where", ["scene folder", "parent folder", "via symlink"])
def test_frame_folder_holding_an_input_is_refused(scene, tmp_path, where):
    folder = os.path.dirname(scene)
    if where == "scene folder":
        out = folder + "/"
    elif where == "parent folder":
        out = str(tmp_path) + "/"
    else:
        os.symlink(folder, tmp_path / "alias")
        out = str(tmp_path / "alias") + "/"
    before = snapshot(tmp_path)
    line = one_error_line(cli("animate", scene, "-o", out))
    assert f"{out}: cannot write: the folder holds a file the scene reads: '{scene}'" in line
    assert snapshot(tmp_path) == before


def test_gif_layer_image_is_not_overwritten_by_animate(tmp_path):
    """An input can be a .gif too: animating onto it is refused."""
    from PIL import Image

    scene = make_bar(tmp_path)
    Image.open(tmp_path / "bar.png").save(tmp_path / "bar.gif")
    text = (tmp_path / "scene.json").read_text().replace("bar.png", "bar.gif")
    (tmp_path / "scene.json").write_text(text)
    before = snapshot(tmp_path)
    line = one_error_line(cli("animate", scene, "-o", tmp_path / "bar.gif"))
    assert "layers[0].image" in line and str(tmp_path / "bar.gif") in line
    assert snapshot(tmp_path) == before


# -- frame folders from an earlier run ------------------------------------------------------
def frames_in(folder):
    return sorted(os.listdir(folder))


def test_rerun_replaces_old_frames_as_a_whole(tmp_path):
    scene = make_bar(tmp_path / "s")
    out = str(tmp_path / "frames") + "/"
    assert cli("animate", scene, "-o", out).returncode == 0
    assert frames_in(out) == [f"frame_{i:05d}.png" for i in range(11)]
    old = snapshot(out)
    r = cli("animate", scene, "-o", out, "--from", "0.5")
    assert r.returncode == 0, r.stderr
    assert frames_in(out) == [f"frame_{i:05d}.png" for i in range(6)], "no old frame left over"
    new = snapshot(out)
    # frame 0 now is the old frame 5 (t = 0.5)
    assert new[os.path.join(out, "frame_00000.png")] == old[os.path.join(out, "frame_00005.png")]
    assert sorted(os.listdir(tmp_path)) == ["frames", "s"]


def test_frame_folder_with_other_files_is_refused(tmp_path):
    scene = make_bar(tmp_path / "s")
    out = tmp_path / "frames"
    out.mkdir()
    (out / "frame_00000.png").write_bytes(b"old frame")
    (out / "notes.txt").write_text("mine")
    before = snapshot(tmp_path)
    line = one_error_line(cli("animate", scene, "-o", str(out) + "/"))
    assert "cannot write: the folder holds other files than frames (e.g. 'notes.txt')" in line
    assert snapshot(tmp_path) == before


# -- 2. outputs that cannot be written ---------------------------------------------------------
@pytest.fixture
def mount(tmp_path):
    m = Mount(tmp_path / "mnt")
    yield m
    m.close()


OUTPUTS = [("render", "o.png"), ("mesh", "o.json"), ("animate", "o.gif"), ("animate", "o.mp4"),
           ("animate", "frames/")]


def _check_refused(scene, out, words, *, command, watch):
    inputs = snapshot(os.path.dirname(scene))
    before = snapshot(*watch)
    line = one_error_line(cli(command, scene, "-o", out))
    assert line.startswith(f"puppet: error: {out}: cannot write: "), line
    assert words in line, line
    assert snapshot(*watch) == before, "nothing written, no temporary left"
    assert snapshot(os.path.dirname(scene)) == inputs
    return line


@pytest.mark.parametrize("command,name", OUTPUTS)
def test_read_only_file_system(scene, mount, command, name):
    mount.read_only()
    _check_refused(scene, os.path.join(mount.where, name), "read-only file system", command=command,
                   watch=[mount.where])


@pytest.mark.parametrize("command,name", OUTPUTS)
def test_full_disk(scene, mount, command, name):
    mount.fill()
    _check_refused(scene, os.path.join(mount.where, name), "No space left on device", command=command,
                   watch=[mount.where])


def test_existing_file_on_a_read_only_file_system_is_kept(scene, mount):
    with open(os.path.join(mount.where, "o.png"), "wb") as f:
        f.write(b"precious")
    mount.read_only()
    _check_refused(scene, os.path.join(mount.where, "o.png"), "read-only", command="render", watch=[mount.where])


def test_immutable_file_is_kept(scene, tmp_path):
    out = tmp_path / "o.png"
    out.write_bytes(b"precious")
    if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", out], capture_output=True).returncode:
        pytest.skip("chattr +i is not available here")
    try:
        _check_refused(scene, str(out), "the file is read-only", command="render", watch=[tmp_path])
    finally:
        subprocess.run(["chattr", "-i", out])


@pytest.mark.parametrize("command,name", OUTPUTS)
def test_missing_parent_folder(scene, tmp_path, command, name):
    out = os.path.join(tmp_path, "no", "such", name)
    _check_refused(scene, out, f"folder '{tmp_path}/no/such' does not exist", command=command, watch=[tmp_path])


@pytest.mark.parametrize("command,name", OUTPUTS)
def test_parent_is_a_file(scene, tmp_path, command, name):
    (tmp_path / "plain").write_text("x")
    out = os.path.join(tmp_path, "plain", name)
    _check_refused(scene, out, f"'{tmp_path}/plain' is not a folder", command=command, watch=[tmp_path])


@pytest.mark.parametrize("command,out,words", [
    ("render", "/proc/o.png", "cannot create files in '/proc'"),
    ("mesh", "/proc/self/o.json", "folder '/proc/"),
    ("animate", "/proc/o.gif", "cannot create files in '/proc'"),
    ("animate", "/proc/frames/", "cannot create files in '/proc'")])
def test_under_proc(scene, command, out, words):
    _check_refused(scene, out, words, command=command, watch=[os.path.dirname(scene)])


def test_symlink_to_a_device_is_not_replaced(scene, tmp_path):
    """As root, renaming over /dev/null would replace the device: refused instead."""
    os.symlink("/dev/null", tmp_path / "o.png")
    stat_before = os.stat("/dev/null")
    _check_refused(scene, str(tmp_path / "o.png"), "not a regular file", command="render", watch=[tmp_path])
    assert os.stat("/dev/null").st_rdev == stat_before.st_rdev and os.path.exists("/dev/null")


def test_output_that_is_a_folder(scene, tmp_path):
    (tmp_path / "o.png").mkdir()
    _check_refused(scene, str(tmp_path / "o.png"), "is a folder", command="render", watch=[tmp_path])


def test_frame_folder_path_that_is_a_file(scene, tmp_path):
    (tmp_path / "frames").write_text("x")
    _check_refused(scene, str(tmp_path / "frames") + "/", "exists and is not a folder", command="animate",
                   watch=[tmp_path])


def test_mount_point_as_frame_folder_is_refused_up_front(scene, mount):
    _check_refused(scene, mount.where + "/", "is a mount point", command="animate", watch=[mount.where])


def test_full_stdout_is_a_user_error(scene):
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(os.path.dirname(__file__))))
    with open("/dev/full", "w") as full:
        r = subprocess.run([sys.executable, "-m", "puppet", "check", scene], stdout=full, stderr=subprocess.PIPE,
                           text=True, env=env)
    assert one_error_line(r) == "puppet: error: stdout: cannot write: No space left on device"


def test_scene_save_goes_through_the_same_checks(scene, tmp_path):
    """Scene.save may overwrite its own scene file, never an image it reads; errors are OutputErrors."""
    import puppet
    from puppet.output import OutputError

    folder = os.path.dirname(scene)
    sc = puppet.load_scene(scene)
    before = snapshot(folder)
    for name in ("bar.png", "mask.png", "bg.png"):
        with pytest.raises(OutputError, match=f"it is a file the scene reads: '{folder}/{name}'"):
            sc.save(os.path.join(folder, name))
    with pytest.raises(OutputError, match="does not exist"):
        sc.save(str(tmp_path / "no" / "s.json"))
    assert snapshot(folder) == before
    sc.save(scene)  # saving over itself is what "save" is for
    assert puppet.load_scene(scene).data.layers[0].image == os.path.join(folder, "bar.png")
    with pytest.raises(OutputError, match="the scene reads"):
        sc.write_mesh(scene)
