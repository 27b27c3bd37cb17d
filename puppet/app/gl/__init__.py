"""puppet.app.gl."""
