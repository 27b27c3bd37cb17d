"""Animation output: ``puppet animate``'s formats in one table (:mod:`.formats`), the
export pipeline (solve, composite and encode on three threads), frame sinks (PNG folder,
GIF, MP4, WebM, APNG, sprite sheet), the web player, Spine and glTF exporters, a solver
child process, and the app's export child."""
