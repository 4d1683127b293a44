"""python -m clbrdf.cli: the command line."""
from . import entry

entry()
