"""Runs: parameter maps, the time-stepping runner, snapshots and provenance."""
