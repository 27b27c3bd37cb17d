"""``puppet batch``: its arguments and how it runs (imported by puppet.cli; keep it cheap to import)."""
from __future__ import annotations

import argparse

from puppet.errors import SceneError


def add_parser(sub, *, size, time) -> argparse.ArgumentParser:
    b = sub.add_parser("batch", help="render many scenes / poses / garment images on Dask")
    b.add_argument("jobs", nargs="?", metavar="JOBS", help="a folder of scenes or a JSON/JSONL job list")
    b.add_argument("-o", "--output", required=True, metavar="OUT_DIR/")
    b.add_argument("--workers", type=int, metavar="N", help="worker processes (default: the cores)")
    b.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="an existing Dask scheduler")
    b.add_argument("--retries", type=int, default=1, metavar="K")
    b.add_argument("--resume", action="store_true", help="skip jobs whose output is up to date")
    return b


def run(args: argparse.Namespace) -> int:
    raise SceneError("puppet batch: not built yet")
