"""``puppet dressroom``: a virtual dressing room, garments fitted on one mannequin, written
as a web page where a shopper puts them on and takes them off.

``command`` (argparse, imported by :mod:`puppet.cli`: no numpy) runs ``model`` (the
mannequin and the garments rendered on its canvas, each with its per-pixel depth from
``depth``) and ``page`` (the self-contained HTML, :file:`room.html` + :file:`room.js`).
It may import ``puppet.anim`` (the web player's safe-script helpers) and everything below.
"""
