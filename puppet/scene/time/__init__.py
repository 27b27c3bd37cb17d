"""puppet.scene.time."""
