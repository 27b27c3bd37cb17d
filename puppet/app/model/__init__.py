"""puppet.app.model."""
