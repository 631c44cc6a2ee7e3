"""``python -m transgen`` runs the command line."""
import sys

from .cli import entry_point

sys.exit(entry_point())
