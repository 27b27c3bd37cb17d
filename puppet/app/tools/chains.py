"""The chain tool of the Deform panel (issue 35): secondary motion's chains of pins
(``physics.chains``, :mod:`puppet.scene.time.physics`).

In Pin mode a click on a pin starts a chain there (its anchor) or adds the pin to the
chain being drawn; a click on the chain's last pin again, or the panel's *Make chain*,
makes it (one undo step); Esc or *Cancel* forgets the draft. A click on a pin of an
existing chain, with no draft, selects that chain (the panel then shows its frequency,
damping and gravity sliders and *Remove chain*). In Pose mode the mode's own tools run
(the chains swing in the playback).
"""
from __future__ import annotations

from puppet.app.tools.gestures import click_or_drag

#: What the panel's sliders start a new chain with: Hz, damping ratio, px/s^2.
FREQUENCY, DAMPING, GRAVITY = 2.0, 0.3, 0.0


def chains(app) -> list[dict]:
    """The scene's chains as the file has them (``physics.chains``), fields filled in."""
    return [{"pins": list(ch.pins), "frequency": ch.frequency, "damping": ch.damping, "gravity": ch.gravity}
            for ch in app.snap.data.chains]


def chain_of(app, pin: str) -> int | None:
    """The index of the chain holding ``pin``, else None."""
    return next((i for i, ch in enumerate(app.snap.data.chains) if pin in ch.pins), None)


def set_chains(app, value: list[dict], done: str) -> int:
    """Replace the scene's chains (one undo step); the status line says ``done`` or the
    scene's one-line refusal."""
    def fn(s):
        s.set_physics(value)
        return done
    return app.edit(fn)


def finish(app, st) -> None:
    """Make the drafted chain (2 pins or more), with the panel's settings."""
    draft = list(st.chain_draft)
    if len(draft) < 2:
        app.say("a chain needs 2 pins or more: click its anchor, then the pins that hang from it", "error")
        return
    st.chain_draft = []
    st.chain = len(app.snap.data.chains)
    set_chains(app, chains(app) + [{"pins": draft, "frequency": FREQUENCY, "damping": DAMPING, "gravity": GRAVITY}],
               f"chain {' > '.join(draft)}: it swings in the playback")


def cancel(app, st) -> None:
    st.chain_draft = []


def remove(app, st, i: int) -> None:
    """Remove chain ``i`` (its pins stay)."""
    value = chains(app)
    if 0 <= i < len(value):
        gone = value.pop(i)
        st.chain = None
        set_chains(app, value, f"removed the chain {' > '.join(gone['pins'])}")


def set_field(app, i: int, field: str, v: float) -> None:
    """Chain ``i``'s ``frequency``, ``damping`` or ``gravity`` (the panel's sliders; the
    slider's drag is one undo step)."""
    value = chains(app)
    if 0 <= i < len(value):
        value[i][field] = float(v)
        app.edit(lambda s: s.set_physics(value), key="chain-live")


def chain_tool(app, st, press):
    """Pin mode: clicks on pins draw a chain, anchor first (see the module)."""
    _, went = yield from click_or_drag(press)
    if went:
        return
    m = app.marker_at(press.pos)
    if m is None or m.kind != "interior":
        app.say("chain: click a pin to start a chain (its anchor), then the pins that hang from it; "
                "click the last one again to make it" if m is None else
                f"{m.name} is not an interior pin: a chain swings interior pins only", "error" if m else "info")
        return
    draft = st.chain_draft
    if draft and m.name == draft[-1]:
        finish(app, st)
        return
    if not draft and (i := chain_of(app, m.name)) is not None:
        st.chain = i
        app.say(f"chain {' > '.join(app.snap.data.chains[i].pins)} selected (Deform panel: its sliders)")
        return
    if m.name in draft or chain_of(app, m.name) is not None:
        app.say(f"{m.name} is in a chain already", "error")
        return
    draft.append(m.name)
    app.say(f"chain: {' > '.join(draft)}" + (" (click the last pin again, or Make chain, to make it)"
                                              if len(draft) >= 2 else " (now the pins that hang from it)"))
