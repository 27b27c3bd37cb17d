"""puppet.app.ui."""
