"""puppet.scene.rig.core."""
