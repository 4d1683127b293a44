"""python -m clbrdf: the command line."""
from .cli import entry

entry()
