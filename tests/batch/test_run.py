"""Batches on the shared embedded cluster: failures are reported and the batch goes on,
outputs equal the in-process renders, --resume renders only what is missing or changed,
template mode transfers and renders each image."""
from __future__ import annotations

import json
import os
import time

import numpy as np
import pytest
from PIL import Image

import puppet
from puppet.batch.jobs import read_job_list
from puppet.batch.runner import run_batch
from tests.batch.conftest import copy_scene, temporaries, write_bar, write_list

pytestmark = pytest.mark.gl


def _png(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGBA"))


def _run(client, tmp_path, entries, **kw):
    out = tmp_path / "out"
    out.mkdir(exist_ok=True)
    jobs = read_job_list(write_list(tmp_path / "jobs.json", entries), os.path.realpath(out), {"budget": 60.0})
    summary = run_batch(jobs, os.path.realpath(out), client=client, **kw)
    with open(summary["report"]) as f:
        return summary, json.load(f), out


def test_mixed_batch_reports_each_failure_and_renders_the_rest(cluster2, tmp_path):
    bar = write_bar(tmp_path / "good")
    bad_img = write_bar(tmp_path / "corrupt")
    (tmp_path / "corrupt" / "bar.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"garbage" * 20)
    (tmp_path / "invalid.json").write_text(json.dumps({"puppet": 1, "layers": "not a list"}))
    entries = [
        {"scene": "good/bar.json", "pose": "bend", "output": "bend.png"},
        {"scene": "corrupt/bar.json", "pose": "bend", "output": "corrupt.png"},
        {"scene": "invalid.json", "output": "invalid.png"},
        {"scene": "good/bar.json", "time": 0.5, "size": [60, 20], "output": "half.png"},
        {"scene": "good/bar.json", "pose": "nope", "output": "nope.png"},
        {"scene": "missing.json", "output": "missing.png"},
        {"scene": "good/bar.json", "animate": {"fps": 4}, "output": "anim.gif"},
        {"scene": "good/bar.json", "output": "deep/er/rest.png"},
    ]
    summary, report, out = _run(cluster2, tmp_path, entries)
    status = {j["output"]: (j["status"], j["error"]) for j in report["jobs"]}
    assert summary["counts"] == {"done": 4, "failed": 4, "no-match": 0, "skipped": 0, "not-run": 0}
    assert report["counts"] == summary["counts"] and report["interrupted"] is False
    assert status["corrupt.png"][0] == "failed" and "bar.png" in status["corrupt.png"][1]
    assert "cannot be read" in status["corrupt.png"][1]
    assert status["invalid.png"][0] == "failed" and "invalid.json" in status["invalid.png"][1]
    assert status["nope.png"][0] == "failed" and "no pose named 'nope'" in status["nope.png"][1]
    assert status["missing.png"][0] == "failed" and "missing.json" in status["missing.png"][1]
    assert all("\n" not in (e or "") for _, e in status.values())
    for name in ("bend.png", "half.png", "anim.gif", "deep/er/rest.png"):
        assert status[name] == ("done", None) and (out / name).is_file()
    for name in ("corrupt.png", "invalid.png", "nope.png", "missing.png"):
        assert not (out / name).exists()
    assert temporaries(out) == []
    # the worker's pixels are the in-process renders' (same compositor path as `puppet render`)
    scene = puppet.load_scene(bar)
    try:
        assert np.array_equal(_png(out / "bend.png"), scene.render(pose="bend"))
        assert np.array_equal(_png(out / "half.png"), scene.render(time=0.5, size=(60, 20)))
    finally:
        scene.close()
    with Image.open(out / "anim.gif") as gif:
        assert gif.n_frames == 5  # 0..1 s at 4 fps
    manifest = json.loads((out / "manifest.json").read_text())["outputs"]
    assert sorted(manifest) == ["anim.gif", "bend.png", "deep/er/rest.png", "half.png"]


def test_a_solve_over_its_budget_fails_alone(cluster2, tmp_path):
    path = copy_scene("trex-layers.json", tmp_path)
    entries = [{"scene": os.path.basename(path), "pose": "roar", "budget": 0.001, "output": "slow.png"},
               {"scene": os.path.basename(path), "pose": "wave", "size": [60, 50], "output": "ok.png"}]
    summary, report, out = _run(cluster2, tmp_path, entries)
    slow, ok = report["jobs"]
    assert slow["status"] == "failed" and "budget of 0.001 s" in slow["error"], slow
    assert ok["status"] == "done" and (out / "ok.png").is_file() and not (out / "slow.png").exists()


@pytest.mark.gl
def test_an_animation_over_its_budget_stops_in_a_frame_solve(tmp_path):
    # in this process: the export solves frames ahead on a thread, where the budget must reach too
    from puppet.anim.export import animate_to
    from puppet.api import Scene
    from puppet.batch.work import BudgetExceeded, _Budgeted

    scene = Scene.load(copy_scene("trex-layers.json", tmp_path))
    out = tmp_path / "slow.gif"
    with pytest.raises(BudgetExceeded, match="the frame's solve ran over the job's budget of 0.01 s"):
        animate_to(_Budgeted(scene, 0.01), str(out), fps=4)
    assert not out.exists() and os.listdir(tmp_path) == ["trex-layers.json"]


@pytest.mark.gl
def test_a_worker_lets_go_of_the_textures_of_scenes_it_dropped(tmp_path, monkeypatch):
    # in this process, as a worker runs jobs: scenes whose layer names all differ
    from puppet.batch import work

    monkeypatch.setattr(work, "SCENE_CACHE", 2)
    monkeypatch.setattr(work, "_scenes", type(work._scenes)())
    monkeypatch.setattr(work, "_compositors", {})
    try:
        for i in range(4):
            path = write_bar(tmp_path / f"s{i}")
            with open(path) as f:
                scene = json.load(f)
            scene["layers"][0]["name"] = f"part{i}"
            for pin in scene["pins"]:
                pin["layer"] = f"part{i}"
            with open(path, "w") as f:
                json.dump(scene, f)
            rec = work.run_job({"id": i, "scene": path, "kind": "pose", "pose": "bend", "size": [30, 10],
                                "output": str(tmp_path / f"o{i}.png"), "rel": f"o{i}.png"})
            assert rec["status"] == "done", rec
            comp = work.compositor()
            assert set(comp._meshes) == {f"part{k}" for k in range(max(0, i - 1), i + 1)}  # the 2 scenes kept
    finally:
        for comp in work._compositors.values():
            comp.release()


def _until(condition, *, timeout: float) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, "still not true after the timeout"
        time.sleep(0.05)


def _stop_after_first(batch, recs):
    raise KeyboardInterrupt


def test_resume_renders_only_what_is_missing_or_changed(cluster2, tmp_path):
    write_bar(tmp_path / "a", colour=(200, 40, 40))
    write_bar(tmp_path / "b", colour=(40, 40, 200))
    entries = [{"scene": f"{s}/bar.json", p: v, "output": f"{s}/{k}.png"}
               for s in "ab" for k, (p, v) in enumerate([("pose", "rest"), ("pose", "bend"), ("time", 0.25),
                                                          ("time", 0.75)])]
    with pytest.raises(KeyboardInterrupt):  # as Ctrl+C would, after the first results
        _run(cluster2, tmp_path, entries, on_result=_stop_after_first)
    out = tmp_path / "out"
    report = json.loads((out / "report.json").read_text())
    manifest = json.loads((out / "manifest.json").read_text())["outputs"]
    assert report["interrupted"] is True and 1 <= report["counts"]["done"] < len(entries)
    assert all((out / rel).is_file() for rel in manifest)  # the manifest never names a missing output
    assert sorted(manifest) == sorted(j["output"] for j in report["jobs"] if j["status"] == "done")
    # a job already running when the batch stopped goes on in this test's shared cluster (a
    # task is cancelled, a running thread is not; `puppet batch` closes its own cluster, and
    # sweeps again after): once it ends, its temporary file is gone too (it becomes an output
    # that the manifest does not list, so --resume renders it again)
    _until(lambda: temporaries(out) == [], timeout=60.0)

    summary, report, _ = _run(cluster2, tmp_path, entries, resume=True)
    skipped = {j["output"] for j in report["jobs"] if j["status"] == "skipped"}
    assert skipped == set(manifest)
    assert summary["counts"]["done"] == len(entries) - len(skipped) and summary["counts"]["failed"] == 0

    # nothing to do: no cluster needed, everything up to date
    summary, report, _ = _run(None, tmp_path, entries, resume=True)
    assert summary["counts"]["skipped"] == len(entries)

    # scene a's image changes and one output of b is deleted: exactly those are rendered again
    write_bar(tmp_path / "a", colour=(10, 160, 10))
    (out / "b" / "1.png").unlink()
    summary, report, _ = _run(cluster2, tmp_path, entries, resume=True)
    done = sorted(j["output"] for j in report["jobs"] if j["status"] == "done")
    assert done == ["a/0.png", "a/1.png", "a/2.png", "a/3.png", "b/1.png"]
    assert tuple(_png(out / "a" / "0.png")[20, 60, :3]) == (10, 160, 10)

    # without --resume every job runs
    summary, _, _ = _run(cluster2, tmp_path, entries)
    assert summary["counts"]["done"] == len(entries)


@pytest.mark.slow
def test_template_mode_transfers_and_renders_each_image(cluster2, tmp_path):
    from puppet.batch.jobs import template_jobs
    from puppet.batch.template import transfer

    template = os.path.join(os.path.dirname(puppet.__file__), "..", "assets", "scenes", "tshirt-garment.json")
    template = os.path.realpath(template)
    shirt = os.path.join(os.path.dirname(template), "..", "noto-emoji", "emoji_u1f455.png")
    dress = os.path.join(os.path.dirname(template), "..", "noto-emoji", "emoji_u1f457.png")
    imgs = tmp_path / "imgs"
    imgs.mkdir()
    im = Image.open(shirt).convert("RGBA")
    im.resize((360, 360)).save(imgs / "small.png")
    im.rotate(10, expand=True).save(imgs / "turned.png")
    Image.open(dress).save(imgs / "dress.png")
    (imgs / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\nnope")
    out = tmp_path / "out"
    out.mkdir()
    jobs = template_jobs(template, str(imgs), "lift", os.path.realpath(out), {"size": [96, 96]}, tolerance=None)
    summary = run_batch(jobs, os.path.realpath(out), client=cluster2)
    report = {j["output"]: j for j in json.loads((out / "report.json").read_text())["jobs"]}
    assert summary["counts"] == {"done": 2, "failed": 1, "no-match": 1, "skipped": 0, "not-run": 0}
    assert report["dress.png"]["status"] == "no-match" and "tolerance" in report["dress.png"]["error"]
    assert report["broken.png"]["status"] == "failed" and "broken.png" in report["broken.png"]["error"]
    for name in ("small.png", "turned.png"):
        assert report[name]["status"] == "done"
        doc = transfer(template, str(imgs / name), tolerance=None)
        scene = puppet.Scene(doc, str(imgs / name))
        try:
            assert np.array_equal(_png(out / name), scene.render(pose="lift", size=(96, 96)))
        finally:
            scene.close()
    # resume: unchanged images are up to date; a changed one is transferred again
    im.resize((300, 300)).save(imgs / "small.png")
    summary = run_batch(jobs, os.path.realpath(out), client=cluster2, resume=True)
    report = {j["output"]: j["status"] for j in json.loads((out / "report.json").read_text())["jobs"]}
    assert report == {"small.png": "done", "turned.png": "skipped", "dress.png": "no-match", "broken.png": "failed"}
