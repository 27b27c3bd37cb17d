"""The animation features on the T-rex in a 1280x800 headless window, as a user sees them;
the screenshots of docs/app.md's Animation section are taken here (docs/app/anim-*.png,
rewritten only when they change)."""
from __future__ import annotations

import os

import numpy as np
import pytest

from tests.app.harness import Driver, pin_keys, widget
from tests.conftest import SCENES

pytestmark = pytest.mark.gl


class Clock:
    """A clock the test moves (recording timed exactly the same every run)."""

    def __init__(self):
        self.now = 1000.0

    def __call__(self):
        return self.now


@pytest.mark.slow
def test_onion_skin_and_a_recording_on_the_trex():
    d = Driver(os.path.join(SCENES, "trex-layers.json"), size=(1280, 800))
    try:
        app, tl = d.app, d.app.timeline
        tl.clock = Clock()
        tl.prefetch = False  # settle() waits for every job: no background solves of 25 frames
        # the onion skin between roar (0.5 s) and wave (1 s): the keys around, tinted
        tl.scrub(0.75)
        d.click(*widget("onion"))
        d.settle(600)  # the T-rex's in-betweens take a while on a loaded machine
        assert sorted(round(g[1], 2) for g in app.snap.ghosts) == [1.0, 1.0]
        d.move(900, 300)
        d.frame(2)
        d.shot("anim-onion")
        # record the front hand: a swing drawn in 2 s at half speed -> 1 s of keys from 0.25 s
        d.click(*widget("onion"))
        d.click(*widget("Record"))
        tl.speed = 0.5
        tl.scrub(0.25)
        d.settle(600)
        a = d.pin_screen("hand_front")
        a = (round(a[0]), round(a[1]))
        d.press(*a)
        for k in range(1, 41):
            tl.clock.now += 0.05
            ang = k / 40 * np.pi
            d.drag(a[0] - round(60 * np.sin(ang)), a[1] - round(130 * (1 - np.cos(ang)) / 2))
        d.release()
        d.settle(600)
        rec = tl.last_recording
        assert rec.times[-1] == pytest.approx(0.25 + 2.0 * 0.5)
        keyed = list(pin_keys(d.scene().keys(), "hand_front"))
        assert keyed[0] == pytest.approx(0.25) and keyed[-1] == pytest.approx(1.25) and len(keyed) < 20
        tl.record = False
        tl.onion.update(mode="frames", count=3)
        tl.onion_on = True
        tl.scrub(0.75)
        d.settle(600)
        assert len(app.snap.ghosts) == 6
        d.move(900, 300)
        d.frame(2)
        d.shot("anim-record")
    finally:
        d.close()
