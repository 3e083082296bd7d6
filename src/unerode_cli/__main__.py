"""``python -m unerode_cli`` runs the command line."""

from unerode_cli.cli.app import main

main()
