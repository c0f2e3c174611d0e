"""The ``adaptsky`` command: one thin Typer module per command group."""
