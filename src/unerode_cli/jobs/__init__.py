"""One module per subcommand: plan (check everything, read inputs), run, write."""
