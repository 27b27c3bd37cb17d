"""puppet.scene.document.core."""
