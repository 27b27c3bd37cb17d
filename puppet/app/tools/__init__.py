"""puppet.app.tools.dispatch."""
