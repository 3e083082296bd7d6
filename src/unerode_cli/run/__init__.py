"""What every job shares: the time-stepping runner, the process registry, the outputs of a
run (which files, history, sidecars, previews), boundaries and parameter maps."""
