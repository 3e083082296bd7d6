"""Thin typer commands: parse options, read, call processes, write. No physics here."""
