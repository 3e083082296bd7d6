"""Surface processes: each returns a change of the terrain, never edits it in place."""
