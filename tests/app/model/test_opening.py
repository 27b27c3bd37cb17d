"""The app's open path on layered art (``puppet app ART``, File > Open): the status line
says what the import did, the backup an update kept first."""
from __future__ import annotations

import os

from puppet.app.model import opening
from tests.cli.test_init_safety import character, write_ora


def test_the_status_line_after_art_was_updated_names_the_backup(tmp_path):
    art = tmp_path / "char.ora"
    write_ora(art, character())
    first = opening.preload(str(art))
    assert first == str(tmp_path / "char.json")
    _, _, status = opening.load(first, picture=False)
    assert "420x600, 7 layer(s)" in status and "note(s)" not in status, status
    write_ora(art, character(rename={"arm_front": "front arm"}))
    again = opening.preload(str(art))
    _, _, status = opening.load(again, picture=False)
    assert "replaced" in status and "note(s): the scene as it was is kept in" in status, status
    assert "char.json.bak" in status and os.path.isfile(tmp_path / "char.json.bak")
    assert status.endswith(" ...)")  # the rename note too, on stderr


def test_art_status_without_notes_is_the_summary():
    class Res:
        notes: list = []

        def summary(self):
            return "s.json: 10x10, 1 layer(s)"
    assert opening.art_status(Res()) == "s.json: 10x10, 1 layer(s)"
