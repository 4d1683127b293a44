"""The layouts renderers load, as described in clbrdf/data (``layouts.json``: albedo tables;
``ltc_layouts.json``: LTC textures), both in one schema (``check_layout``): read, never
computed, so that the command line can list them before it imports anything that computes."""
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


PRODUCTS = {"albedo": "clbrdf table --layout", "ltc": "clbrdf ltc --layout"}
# the schema: keys every layout has, keys it may have, keys of its tables
REQUIRED = ("product", "consumer", "source", "model", "tables")
OPTIONAL = {"albedo": ("fixed", "samples", "target_stderr", "target_basis", "encoding",
                       "notes", "formats"),
            "ltc": ("form", "encoding", "texel", "planar", "notes", "formats")}
TABLE_REQUIRED = ("name", "quantity", "axes")
TABLE_OPTIONAL = ("range", "model", "fixed", "estimator", "samples", "target_stderr",
                  "target_basis")
ENCODINGS = ("float32", "float16", "unorm16")


def check_layout(name: str, lay: dict) -> list:
    """What is wrong with layout ``name``'s description against the one schema of both files
    (REQUIRED, OPTIONAL, TABLE_REQUIRED, TABLE_OPTIONAL): a list of sentences, empty when it
    is well formed. An LTC layout's tables are on one grid (the fit's)."""
    bad = [f"{name}: no {k}" for k in REQUIRED if k not in lay]
    product = lay.get("product")
    if product not in PRODUCTS:
        return bad + [f"{name}: product {product!r} is not one of {', '.join(PRODUCTS)}"]
    bad += [f"{name}: unknown key {k!r}" for k in lay if k not in REQUIRED + OPTIONAL[product]]
    if lay.get("encoding", "float32") not in ENCODINGS:
        bad.append(f"{name}: encoding {lay['encoding']!r} is not one of {', '.join(ENCODINGS)}")
    tables = lay.get("tables") or []
    if "tables" in lay and not tables:
        bad.append(f"{name}: no tables")
    for t in tables:
        what = f"{name}, table {t.get('name', '?')}"
        bad += [f"{what}: no {k}" for k in TABLE_REQUIRED if k not in t]
        bad += [f"{what}: unknown key {k!r}" for k in t
                if k not in TABLE_REQUIRED + TABLE_OPTIONAL]
        if not isinstance(t.get("axes"), list) or not all(isinstance(a, str) for a in t["axes"]):
            bad.append(f"{what}: axes are not a list of axis texts")
    if product == "ltc" and len({tuple(t.get("axes", ())) for t in tables}) > 1:
        bad.append(f"{name}: an LTC layout's tables have different axes")
    names = [t.get("name") for t in tables]
    bad += [f"{name}: table {n} is given twice" for n in set(names) if names.count(n) > 1]
    return bad


def ltc_textures(lay: dict) -> dict:
    """An LTC layout's textures: {name: its channels, the fit's quantities in texel order}."""
    return {t["name"]: list(t["quantity"]) for t in lay["tables"]}


def ltc_axes(lay: dict) -> list:
    """The axis texts of an LTC layout's fit (every table's)."""
    return list(lay["tables"][0]["axes"])


def get_ltc_layout(name: str) -> dict:
    """LTC layout ``name``'s description."""
    lays = ltc_layouts()
    if name not in lays:
        raise ParameterError(f"{given('layout', name)} is not an LTC layout: choose one of "
                             f"{', '.join(sorted(lays))}", "layout")
    return lays[name]


def ltc_formats(name: str) -> tuple:
    """The suffixes LTC layout ``name`` is written as (its "formats")."""
    return tuple(get_ltc_layout(name)["formats"])


def get_layout(name: str) -> dict:
    all_ = layouts()
    if name not in all_:
        raise ParameterError(f"layout={name!r} is not known: choose one of {', '.join(all_)}")
    return all_[name]
