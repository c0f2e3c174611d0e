"""Consoles shared by the commands: results on stdout, messages on stderr (no markup, no
emoji codes: user text such as `cuda:-1:` or a path with `:smile:` is printed as it is)."""

from rich.console import Console

out = Console(highlight=False, emoji=False)
err = Console(stderr=True, highlight=False, markup=False, emoji=False, soft_wrap=True)
