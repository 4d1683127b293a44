"""The layouts renderers load, as described in clbrdf/data (``layouts.json``: albedo tables;
``ltc_layouts.json``: LTC textures): read, never computed, so that the command line can list
them before it imports anything that computes."""
from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources

from ..models.spec import ParameterError, given


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


def ltc_formats(name: str) -> tuple:
    """The suffixes LTC layout ``name`` is written as (its "formats")."""
    lays = ltc_layouts()
    if name not in lays:
        raise ParameterError(f"{given('layout', name)} is not an LTC layout: choose one of "
                             f"{', '.join(sorted(lays))}", "layout")
    return tuple(lays[name]["formats"])


def get_layout(name: str) -> dict:
    all_ = layouts()
    if name not in all_:
        raise ParameterError(f"layout={name!r} is not known: choose one of {', '.join(all_)}")
    return all_[name]
