"""Job lists, scene folders and template folders become jobs; command errors are one line,
exit status 2, and touch nothing (no cluster is started by these tests)."""
from __future__ import annotations

import json
import os

import pytest

from puppet.batch import jobs as J
from puppet.errors import SceneError
from tests.batch.conftest import write_bar, write_list


def _read(tmp_path, entries, name="jobs.json"):
    out = os.path.realpath(tmp_path / "out")
    return J.read_job_list(write_list(tmp_path / name, entries), out, {"size": None, "budget": 5.0}), out


def test_list_paths_relative_to_the_list_and_outputs_inside_out_dir(tmp_path):
    (tmp_path / "sub").mkdir()
    write_bar(tmp_path / "sub")
    jobs, out = _read(tmp_path, [{"scene": "sub/bar.json", "pose": "bend", "output": "a/b.png"},
                                 {"scene": "sub/bar.json", "time": 0.5, "size": "60x20"},
                                 {"scene": "sub/bar.json", "animate": {"fps": 5}, "output": "anim/"},
                                 {"scene": "sub/bar.json"}])
    assert [j["id"] for j in jobs] == [0, 1, 2, 3]
    assert jobs[0]["scene"] == str(tmp_path / "sub" / "bar.json")
    assert jobs[0]["output"] == os.path.join(out, "a", "b.png") and jobs[0]["rel"] == "a/b.png"
    assert (jobs[1]["kind"], jobs[1]["time"], jobs[1]["size"], jobs[1]["rel"]) == ("time", 0.5, [60, 20], "bar/t0_5.png")
    assert jobs[2]["kind"] == "animate" and jobs[2]["animate"] == {"fps": 5.0} and jobs[2]["rel"] == "anim/"
    assert (jobs[3]["kind"], jobs[3]["pose"], jobs[3]["rel"]) == ("pose", "rest", "bar/rest.png")
    assert all(j["budget"] == 5.0 for j in jobs)


def test_jsonl_list_and_its_line_numbers(tmp_path):
    write_bar(tmp_path)
    (tmp_path / "jobs.jsonl").write_text('{"scene": "bar.json", "pose": "bend"}\n\n{"scene": "bar.json", "time": 1}\n')
    jobs = J.read_job_list(str(tmp_path / "jobs.jsonl"), str(tmp_path / "out"), {})
    assert [j["kind"] for j in jobs] == ["pose", "time"]
    (tmp_path / "bad.jsonl").write_text('{"scene": "bar.json"}\n{"scene": "bar.json", "pose": 3}\n')
    with pytest.raises(SceneError, match=r"bad.jsonl: line 2.pose: pose must be a pose name"):
        J.read_job_list(str(tmp_path / "bad.jsonl"), str(tmp_path / "out"), {})
    (tmp_path / "broken.jsonl").write_text('{"scene": "bar.json"}\n{"scene": \n')
    with pytest.raises(SceneError, match=r"line 2\S*: invalid JSON at column"):
        J.read_job_list(str(tmp_path / "broken.jsonl"), str(tmp_path / "out"), {})


@pytest.mark.parametrize("entry, message", [
    ({"scene": "s.json", "output": "../x.png"}, "leaves OUT_DIR"),
    ({"scene": "s.json", "output": "/tmp/x.png"}, "must be relative"),
    ({"scene": "s.json", "output": "report.json"}, "batch's own"),
    ({"scene": "s.json", "output": "x.gif"}, "a frame goes to a .png"),
    ({"scene": "s.json", "animate": True, "output": "x.png"}, "an animation goes to"),
    ({"scene": "s.json", "pose": "a", "time": 1}, "not pose and time"),
    ({"scene": "s.json", "time": -1}, "time must be"),
    ({"scene": "s.json", "size": [0, 10]}, "size"),
    ({"scene": "s.json", "size": "big"}, "size must be"),
    ({"scene": "s.json", "colour": 1}, "unknown key 'colour'"),
    ({"pose": "a"}, "'scene'"),
    ([1, 2], "a job is an object"),
])
def test_bad_entries_name_the_list_and_the_job(tmp_path, entry, message):
    with pytest.raises(SceneError, match=message) as e:
        _read(tmp_path, [{"scene": "s.json"}, entry])
    assert "jobs.json: [1]" in str(e.value) and "\n" not in str(e.value)


def test_symlink_out_of_out_dir_and_duplicate_outputs_are_refused(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "elsewhere").mkdir()
    os.symlink(tmp_path / "elsewhere", out / "link")
    with pytest.raises(SceneError, match="leaves OUT_DIR"):
        _read(tmp_path, [{"scene": "s.json", "output": "link/x.png"}])
    with pytest.raises(SceneError, match="jobs 0 and 1 both write 'a/x.png'"):
        _read(tmp_path, [{"scene": "s.json", "output": "a/x.png"}, {"scene": "t.json", "output": "a/./x.png"}])
    with pytest.raises(SceneError, match="inside an animation folder"):
        _read(tmp_path, [{"scene": "s.json", "animate": True, "output": "a/"}, {"scene": "t.json", "output": "a/x.png"}])


def test_folder_gives_every_pose_and_the_animation_and_a_job_for_a_bad_scene(tmp_path):
    write_bar(tmp_path)
    (tmp_path / "broken.json").write_text("{not json")
    (tmp_path / "notes.txt").write_text("not a scene")
    jobs = J.folder_jobs(str(tmp_path), str(tmp_path / "out"), {"size": [30, 10]})
    assert [(j["kind"], j["rel"]) for j in jobs] == [
        ("pose", "bar/rest.png"), ("pose", "bar/bend.png"), ("animate", "bar/animation.gif"),
        ("pose", "broken/rest.png")]
    assert all(j["size"] == [30, 10] for j in jobs)
    (tmp_path / "empty").mkdir()
    with pytest.raises(SceneError, match="no scene files"):
        J.folder_jobs(str(tmp_path / "empty"), str(tmp_path / "out"), {})


def test_template_jobs_one_per_image(tmp_path):
    imgs = tmp_path / "imgs"
    imgs.mkdir()
    for n in ("b.png", "a.png", "a.jpg", "c.txt"):
        (imgs / n).write_bytes(b"not read when the jobs are made")
    jobs = J.template_jobs("/t/garment.json", str(imgs), "lift", str(tmp_path / "out"), {}, tolerance=0.1)
    assert [(os.path.basename(j["image"]), j["rel"]) for j in jobs] == [
        ("a.jpg", "a_jpg.png"), ("a.png", "a_png.png"), ("b.png", "b.png")]
    assert all(j["kind"] == "template" and j["pose"] == "lift" and j["tolerance"] == 0.1 for j in jobs)


def test_spec_changes_with_what_decides_the_output():
    a = {"kind": "pose", "pose": "x", "size": None, "rel": "a.png", "budget": 1}
    assert J.spec(a) == J.spec(dict(a, budget=9))
    assert J.spec(a) != J.spec(dict(a, size=[10, 10])) and J.spec(a) != J.spec(dict(a, pose="y"))


# -- the command's own errors: one line, exit 2, nothing written ------------------------
@pytest.mark.parametrize("argv, message", [
    (["batch", "-o", "OUT"], "give JOBS"),
    (["batch", "--template", "t.json", "-o", "OUT"], "--template needs --images and --pose"),
    (["batch", "LIST", "--pose", "x", "-o", "OUT"], "--pose is for template mode"),
    (["batch", "LIST", "--workers", "0", "-o", "OUT"], "--workers"),
    (["batch", "LIST", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1", "-o", "OUT"], "--workers is for"),
    (["batch", "missing.json", "-o", "OUT"], "missing.json: no such file"),
    (["batch", "LIST", "-o", "OUT"], "leaves OUT_DIR"),
])
def test_command_errors(tmp_path, capsys, argv, message):
    from puppet.cli import main

    write_bar(tmp_path)
    lst = write_list(tmp_path / "jobs.json", [{"scene": "bar.json", "output": "../escape.png"}])
    argv = [a.replace("LIST", lst).replace("OUT", str(tmp_path / "out")).replace("missing", str(tmp_path / "missing"))
            for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("puppet: error: ") and message in err and err.count("\n") == 1, err
    assert not (tmp_path / "out").exists() and not (tmp_path / "escape.png").exists()


def test_template_pose_must_exist(tmp_path, capsys):
    from puppet.cli import main

    t = write_bar(tmp_path)
    (tmp_path / "imgs").mkdir()
    assert main(["batch", "--template", t, "--images", str(tmp_path / "imgs"), "--pose", "nope",
                 "-o", str(tmp_path / "out")]) == 2
    assert "--pose 'nope': no such pose (poses: rest, bend)" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_parsing_the_command_loads_no_dask():
    import subprocess
    import sys

    code = ("import sys, puppet.cli as c; c.build_parser().parse_args(['batch', 'x', '-o', 'y']); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed', 'tqdm', 'moderngl')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def _jobs(spec: str, animate: str = "") -> list[dict]:
    return [{"id": i, "scene": s, "kind": k} for i, (s, k) in enumerate(
        [(s, "pose") for s in spec] + [(s, "animate") for s in animate])]


def _ids(piece: list[dict]) -> list[int]:
    return [j["id"] for j in piece]


def test_feeder_gives_animations_first_then_a_worker_keeps_its_scene():
    from puppet.batch.feed import Feeder

    f = Feeder(_jobs("a" * 10 + "b" * 6, animate="ab"))
    assert len(f) == 18
    assert _ids(f.next("w1", 2)) == [16] and _ids(f.next("w2", 2)) == [17]  # animations, one per task
    # 16 left, 2 workers: pieces of ceil(16 / 8) = 2; w1 starts the larger scene, w2 the other
    assert _ids(f.next("w1", 2)) == [0, 1]
    assert _ids(f.next("w2", 2)) == [10, 11]
    assert _ids(f.next("w1", 2)) == [2, 3]    # its own scene again (built there)
    assert _ids(f.next("w2", 2)) == [12, 13]
    assert _ids(f.next("w1", 2)) == [4]       # 8 left: pieces of 1 as the batch ends
    assert f.built == {"w1": {"a"}, "w2": {"b"}}


def test_feeder_shares_a_scene_only_when_a_worker_has_nothing_of_its_own():
    from puppet.batch.feed import Feeder

    f = Feeder(_jobs("a" * 12 + "b" * 4))  # pieces of 2
    assert _ids(f.next("w1", 2)) == [0, 1] and _ids(f.next("w2", 2)) == [12, 13]
    assert _ids(f.next("w2", 2)) == [14, 15]  # finishes b
    assert _ids(f.next("w2", 2)) == [2, 3]    # nothing unstarted: helps with a (10 left)
    assert f.built["w2"] == {"a", "b"}
    while f.next("w1", 2):
        pass
    assert len(f) == 0 and f.next("w2", 2) == []
    # a rest too small to pay a second build is left to the worker that has the scene
    f = Feeder(_jobs("a" * 2))
    assert _ids(f.next("w1", 2)) == [0]
    assert f.next("w2", 2) == []
    assert _ids(f.next("w1", 2)) == [1]


def test_feeder_shares_a_scene_only_when_its_build_pays_off():
    from puppet.batch.feed import Feeder

    def fed(n: int, job: float, build: float) -> list[dict]:
        """w1 took the first piece of n jobs of one scene and sent back its times (the first
        job built the scene); what does w2 get?"""
        f = Feeder(_jobs("a" * n))
        done = f.next("w1", 2)
        f.learn(done, [{"id": j["id"], "status": "done", "seconds": job + build if i == 0 else job}
                       for i, j in enumerate(done)])
        return f.next("w2", 2)

    # 23 jobs, first piece ceil(23 / 8) = 3: 20 jobs of 40 ms left, a 250 ms build: balanced
    # when w2 takes (0.8 - 0.25) / 0.08 = 6 jobs, in pieces of a quarter of a worker's share
    # of the 0.8 s left: 0.1 s, 2 jobs
    assert len(fed(23, 0.04, 0.25)) == 2
    assert fed(10, 0.04, 0.25) == []            # 8 left, 0.32 s: not worth a 0.25 s build and two jobs
    assert len(fed(10, 0.04, 0.0)) == 1         # nothing to build: help (pieces of 1 at the end)
    f = Feeder(_jobs("ab"))
    f.learn([{"id": 0, "scene": "a"}], [{"id": 0, "status": "failed", "seconds": 9.0}])
    assert f.stats == {}                        # failed jobs teach nothing


def test_feeder_sizes_pieces_by_time_once_jobs_are_timed():
    from puppet.batch.feed import Feeder

    f = Feeder(_jobs("a" * 40 + "b" * 40))
    assert f.piece_size(2, "a") == 8                   # untimed: ceil(80 / 8) jobs, at most 8
    assert Feeder(_jobs("a" * 20)).piece_size(2, "a") == 3
    pa, pb = f.next("w1", 2), f.next("w2", 2)
    assert [len(pa), len(pb), pa[0]["scene"], pb[0]["scene"]] == [8, 8, "a", "b"]
    f.learn(pa, [{"id": j["id"], "status": "done", "seconds": 0.1} for j in pa])
    f.learn(pb, [{"id": j["id"], "status": "done", "seconds": 0.01} for j in pb])
    # 32 jobs x 0.1 s + 32 x 0.01 s = 3.52 s left; a quarter of a worker's share is 0.44 s
    assert f.piece_size(2, "a") == 4 and f.piece_size(2, "b") == 8  # 44 jobs of 10 ms: at most 8
    while "b" in f.queues:
        assert f.next("w2", 2)[0]["scene"] == "b"
    sizes = []
    while "a" in f.queues:
        sizes.append(len(f.next("w1", 2)))
    assert sizes[0] == 4 and sizes[-1] == 1 and sizes == sorted(sizes, reverse=True)  # shrinking
    assert sum(sizes) == 32 and len(f) == 0


def test_feeder_splits_a_scene_early_when_its_owner_would_end_the_batch_alone():
    from puppet.batch.feed import Feeder

    def second_piece(spec: str) -> list[dict]:
        f = Feeder(_jobs(spec))
        first = f.next("w1", 2)
        assert {j["scene"] for j in first} == {"a"}
        f.learn(first, [{"id": j["id"], "status": "done", "seconds": 0.15 if i == 0 else 0.1}
                        for i, j in enumerate(first)])
        return f.next("w2", 2)

    # a: 34 jobs x 0.1 s left, b and c 0.4 s each: a is 3.4 of 4.2 s, far over a worker's share
    piece = second_piece("a" * 40 + "b" * 4 + "c" * 4)
    assert {j["scene"] for j in piece} == {"a"} and len(piece) == 5
    # b and c as large as a: a new scene instead (no second build of a)
    assert {j["scene"] for j in second_piece("a" * 40 + "b" * 40 + "c" * 40)} == {"b"}


def test_feeder_takes_back_the_pieces_of_a_worker_that_died():
    from puppet.batch.feed import Feeder

    f = Feeder(_jobs("a" * 6 + "b" * 2, animate="c"))
    anim = f.next("w1", 2)
    assert _ids(anim) == [8]
    p1, p2 = f.next("w1", 2), f.next("w2", 2)
    assert {j["scene"] for j in p1} == {"a"} and {j["scene"] for j in p2} == {"b"}
    rest_a = []
    while "a" in f.queues:  # w1 keeps to its scene
        rest_a.append(f.next("w1", 2))
    assert all(j["scene"] == "a" for p in rest_a for j in p) and f.out["a"] == 6  # none back
    f.forget("w1")
    for piece in reversed([anim, p1] + rest_a):  # the last first, as the dispatch does
        f.put_back(piece)
    assert len(f) == 1 + 6 + (2 - len(p2)) and f.out == {"b": len(p2)}
    assert "w1" not in f.built and f.queues["a"][0]["id"] == _ids(p1)[0]  # in their order again
    assert _ids(f.next("w2", 1)) == [8]  # the animation first, as before
    got = []
    while piece := f.next("w2", 1):
        got += _ids(piece)
    assert sorted(got) == sorted(list(range(6)) + [7] * (2 - len(p2))) and len(f) == 0


def test_workers_with_several_threads_get_a_warning():
    from puppet.batch.runner import threads_warning

    assert threads_warning({"tcp://a:1": {"nthreads": 1}, "tcp://b:1": {"nthreads": 1}}) is None
    line = threads_warning({"tcp://a:1": {"nthreads": 4}, "tcp://b:1": {"nthreads": 1}})
    assert line.startswith("puppet batch: 1 of 2 workers have up to 4 threads") and "--nthreads 1" in line


def test_feeder_hands_out_a_scene_whose_only_worker_died():
    """The scene's only worker died with a piece (put back): its jobs go to the worker that
    replaces it, even where sharing the scene would not pay a build (it used to wait for
    an owner that was gone: the batch hung)."""
    from puppet.batch.feed import Feeder

    f = Feeder(_jobs("a" * 16))
    done = f.next("w1", 1)
    f.learn(done, [{"id": j["id"], "status": "done", "seconds": 2.04 if i == 0 else 0.04}
                   for i, j in enumerate(done)])
    lost = f.next("w1", 1)
    f.forget("w1")
    f.put_back(lost)
    assert len(f) == 16 - len(done)
    got = []
    while piece := f.next("w2", 1):
        got += _ids(piece)
    assert sorted(got) == list(range(len(done), 16)) and len(f) == 0
