"""LTC tables in the layouts engines load (clbrdf/data/ltc_layouts.json): ``ltc_layout`` fits
them (clbrdf.fit_ltc) and packs the fit into the layout's textures (clbrdf.tables.textures), all
as tables {name: Table}: ``save_tables`` writes them to a .js ES module for three.js, a C header
of the texture arrays, or the tables' own .npz, .exr and .csv, as the layout's "formats" allow
(``catalog.ltc_formats``), and ``load_tables`` reads the last three back."""
from __future__ import annotations

from ..models.spec import ParameterError
from .axes import parse_axis
from .catalog import ltc_axes, ltc_layouts
from .ltc import fit_ltc
from .textures import textures

SUFFIXES = (".js", ".h", ".npz", ".exr")       # what an LTC layout is written as by default


def _layout(name: str) -> dict:
    lays = ltc_layouts()
    if name not in lays:
        raise ParameterError(f"layout={name!r} is not an LTC layout: choose one of "
                             f"{', '.join(sorted(lays))}")
    return lays[name]


def ltc_layout(name: str, model: str | None = None, **kw) -> dict:
    """The layout's tables: the fit (a fit_ltc Table named "ltc" over its axes) and its
    textures {NAME: Table}; ``model`` replaces the layout's (any isotropic reflection model),
    ``kw`` go to fit_ltc (parameters, options, samples, device, ...)."""
    lay = _layout(name)
    axes = {}
    for text in ltc_axes(lay):
        ax = parse_axis(text)
        axes[ax["name"]] = ax
    fit = fit_ltc(model or lay["model"], axes, **{"form": lay.get("form", "general"), **kw})
    return {"ltc": fit, **textures(name, fit)}
