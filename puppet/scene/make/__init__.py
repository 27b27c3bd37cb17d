"""puppet.scene.make."""
