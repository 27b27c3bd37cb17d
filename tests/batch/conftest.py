"""Batch fixtures: one embedded Dask cluster (2 worker processes) shared by the batch tests,
and small scenes written to temporary folders."""
from __future__ import annotations

import json
import os
import shutil

import pytest

from tests.conftest import SCENES, bar_image, bar_scene, write_rgba


@pytest.fixture(scope="package")
def client():
    """A client on an embedded LocalCluster of 2 spawned worker processes (one thread each)."""
    from puppet.batch.cluster import connect

    with connect(workers=2, retries=2) as (c, _):
        c.wait_for_workers(2, timeout=120)
        yield c


@pytest.fixture
def cluster2(client):
    """The shared client, once its 2 workers are there (a test may have killed one)."""
    client.wait_for_workers(2, timeout=120)
    return client


def write_bar(folder, name="bar.json", colour=(200, 40, 40), image="bar.png", **changes) -> str:
    """The bar scene of tests/conftest.py (poses rest, bend; a 1 s animation) in ``folder``."""
    os.makedirs(folder, exist_ok=True)
    write_rgba(os.path.join(folder, image), bar_image(colour=colour))
    scene = dict(bar_scene(), **changes)
    scene["layers"] = [{"name": "bar", "image": image}]
    path = os.path.join(folder, name)
    with open(path, "w") as f:
        json.dump(scene, f)
    return path


def write_list(path, jobs) -> str:
    with open(path, "w") as f:
        json.dump(jobs, f)
    return str(path)


def copy_scene(name: str, folder) -> str:
    """A bundled scene copied with its files' folders resolved (paths made absolute)."""
    with open(os.path.join(SCENES, name)) as f:
        raw = json.load(f)
    from puppet.scene.format.write import map_paths

    raw = map_paths(raw, lambda p: os.path.normpath(os.path.join(SCENES, p)))
    path = os.path.join(folder, name)
    with open(path, "w") as f:
        json.dump(raw, f)
    return path


def temporaries(folder) -> list[str]:
    return [os.path.join(d, n) for d, dirs, files in os.walk(folder) for n in files + dirs if n.endswith(".tmp")]


__all__ = ["write_bar", "write_list", "copy_scene", "temporaries", "shutil"]
