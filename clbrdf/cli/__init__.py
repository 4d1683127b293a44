"""The command line: ``clbrdf COMMAND ...`` (``main``), argument parsing and printing only.

``common`` holds what the commands share, one module per command group (``models``, ``tables``,
``sweeps``, ``studies``) its commands and their parsers, ``main`` the parser and the error
handling.
"""
from .main import entry, main

__all__ = ["entry", "main"]
