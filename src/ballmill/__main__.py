"""`python -m ballmill` is the `ballmill` command."""

from .cli import main

main()
