"""LTC tables in the layouts engines load (clbrdf/data/ltc_layouts.json): ``ltc_layout`` fits
them (clbrdf.fit_ltc) and packs the fit into the layout's textures (clbrdf.tables.textures), all
as tables {name: Table}: ``save_tables`` writes them to a .js ES module for three.js, a C header
of the texture arrays, or the tables' own .npz, .exr and .csv, as the layout's "formats" allow
(``catalog.ltc_formats``), and ``load_tables`` reads the last three back."""
from __future__ import annotations

from .axes import parse_axis
from .catalog import get_ltc_layout, ltc_axes
from .ltc import fit_ltc
from .textures import textures

SUFFIXES = (".js", ".h", ".npz", ".exr")       # every suffix an LTC layout may be written as


def layout_axes(name: str) -> dict:
    """LTC layout ``name``'s fit axes {name: axis dict}, from its tables' axis texts."""
    axes = {}
    for text in ltc_axes(get_ltc_layout(name)):
        ax = parse_axis(text)
        axes[ax["name"]] = ax
    return axes


def ltc_layout(name: str, model: str | None = None, **kw) -> dict:
    """The layout's tables: the fit (a fit_ltc Table named "ltc" over its axes) and its
    textures {NAME: Table}; ``model`` replaces the layout's (any isotropic reflection model),
    ``kw`` go to fit_ltc (parameters, options, samples, device, ...)."""
    lay = get_ltc_layout(name)
    fit = fit_ltc(model or lay["model"], layout_axes(name),
                  **{"form": lay.get("form", "general"), **kw})
    return {"ltc": fit, **textures(name, fit)}
