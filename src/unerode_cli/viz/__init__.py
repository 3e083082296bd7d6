"""Hillshade previews and plots (matplotlib, Agg backend)."""
