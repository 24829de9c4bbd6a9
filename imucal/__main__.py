"""``python -m imucal`` runs the command line."""

from .cli import main

main()
