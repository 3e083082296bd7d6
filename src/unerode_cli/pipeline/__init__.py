"""Pipeline specs (YAML chains of subcommands) and the pipeline runner."""
