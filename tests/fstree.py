"""What a folder holds, to compare before and after a command: the safety tests and the
campaign scripts check that nothing outside a command's outputs changed."""
from __future__ import annotations

import hashlib
import os
import stat


def digest(data: bytes) -> str:
    """The digest :func:`snapshot` gives a regular file holding ``data``."""
    return hashlib.blake2b(data, digest_size=16).hexdigest()


def snapshot(folder: str) -> dict[str, tuple]:
    """Every entry under ``folder`` by its path relative to it: ``("file", digest, size)``,
    ``("link", target)``, ``("dir",)`` or ``("other", file type)``; links and FIFOs are
    not followed, files are read in blocks."""
    found = {}
    for d, dirs, files in os.walk(folder):
        for n in dirs + files:
            p = os.path.join(d, n)
            st = os.lstat(p)
            rel = os.path.relpath(p, folder)
            if stat.S_ISLNK(st.st_mode):
                found[rel] = ("link", os.readlink(p))
            elif stat.S_ISREG(st.st_mode):
                h = hashlib.blake2b(digest_size=16)
                with open(p, "rb") as f:
                    while block := f.read(1 << 20):
                        h.update(block)
                found[rel] = ("file", h.hexdigest(), st.st_size)
            elif stat.S_ISDIR(st.st_mode):
                found[rel] = ("dir",)
            else:
                found[rel] = ("other", stat.S_IFMT(st.st_mode))
    return found
