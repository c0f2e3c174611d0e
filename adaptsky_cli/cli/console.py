"""Consoles shared by the commands: results on stdout, messages on stderr (no markup)."""

from rich.console import Console

out = Console(highlight=False)
err = Console(stderr=True, highlight=False, markup=False, soft_wrap=True)
