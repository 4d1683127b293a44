"""The layouts renderers load, as described in clbrdf/data (``layouts.json``: albedo tables;
``ltc_layouts.json``: LTC textures): read, never computed, so that the command line can list
them before it imports anything that computes."""
from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources

from ..models.spec import ParameterError


@lru_cache(maxsize=None)
def _read(name: str) -> str:
    return resources.files("clbrdf").joinpath(f"data/{name}").read_text(encoding="utf-8")


def layouts() -> dict:
    """Every albedo-table layout: name -> its description (the JSON entry)."""
    return {k: v for k, v in json.loads(_read("layouts.json")).items() if not k.startswith("_")}


def ltc_layouts() -> dict:
    """Every LTC layout: name -> its description."""
    return {k: v for k, v in json.loads(_read("ltc_layouts.json")).items()
            if not k.startswith("_")}


def get_layout(name: str) -> dict:
    all_ = layouts()
    if name not in all_:
        raise ParameterError(f"layout={name!r} is not known: choose one of {', '.join(all_)}")
    return all_[name]
