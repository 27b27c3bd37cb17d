"""puppet.scene.drag.session."""
