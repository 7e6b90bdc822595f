"""Showing a mesh: PNG pictures and plots (render) and the interactive views (view)."""
