"""puppet.scene.format."""
