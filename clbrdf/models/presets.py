"""Material presets: published fits of BRDF models to the 100 MERL materials.

The fits ship with the package (``clbrdf/data/published_fits``, with ``SOURCES.md``). A model
module declares which fits belong to it in ``PRESETS``: a dict from a fit file to a function that
turns one material's fit into ``(options, params)`` for ``Model(name, channels=3, ...)``, or to
``(model name, function)`` when the module defines several models (or a list of them, for a file
that several models take). The first file listed for a model is its default source;
``MATERIAL:SOURCE`` picks another (``alum-bronze:E1``).

>>> clbrdf.Model("low_microfacet", preset="alum-bronze")
>>> clbrdf.presets.get("beckmann", "alum-bronze:E1").params
"""
from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path

from .. import models
from .spec import ParameterError

ATTRIBUTION = {
    "low_lowsmooth_E2.fit": "Löw et al. 2012 supplemental material (E2 fits), via bsdfbenchmark/bbm fits/ (BSD-3-Clause)",
    "low_lowsmooth_E2.json": "Löw et al. 2012 supplemental material (E2 fits), via bsdfbenchmark/bbm fits/ (BSD-3-Clause)",
    "low_lowmicrofacet_E2.fit": "Löw et al. 2012 (parameters credited to J. Kronander), via bsdfbenchmark/bbm fits/ (BSD-3-Clause)",
    "abc_low2012_fits.csv": "Löw et al. 2012 (parameters credited to J. Kronander), via jdupuy/dj_brdf (public domain)",
    "sgd_bagher2012_fits.csv": "Bagher, Soler & Holzschuch 2012, via jdupuy/dj_brdf djb::sgd (public domain)",
    "low_cooktorrance_E1.fit": "Löw et al. 2012 (Cook-Torrance fits, E1 metric), via bsdfbenchmark/bbm fits/ (BSD-3-Clause)",
    "low_cooktorrance_E2.fit": "Löw et al. 2012 (Cook-Torrance fits, E2 metric), via bsdfbenchmark/bbm fits/ (BSD-3-Clause)",
    "low_ashikhminshirley_E1.fit": "Löw et al. 2012 (Ashikhmin-Shirley fits, E1 metric), via bsdfbenchmark/bbm fits/ (BSD-3-Clause)",
    "low_ashikhminshirley_E2.fit": "Löw et al. 2012 (Ashikhmin-Shirley fits, E2 metric), via bsdfbenchmark/bbm fits/ (BSD-3-Clause)",
    "openpbr_diffuse.csv": "OpenPBR Surface 1.1 defaults (Academy Software Foundation), diffuse lobe",
    "openpbr_specular.csv": "OpenPBR Surface 1.1 defaults (Academy Software Foundation), specular lobes",
    "metals_rgb.csv": "Johnson & Christy 1972 (Au, Ag, Cu), 1974 (Cr), Rakic 1995 (Al), via the refractiveindex.info database (CC0)",
}


@dataclass(frozen=True)
class Preset:
    material: str
    model: str
    source: str                      # fit file
    options: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)

    @property
    def attribution(self) -> str:
        return ATTRIBUTION.get(self.source, self.source)

    def kwargs(self) -> dict:
        """Keyword arguments for ``Model``: channels=3, the options and the parameters."""
        return {"channels": 3, **self.options, **self.params}


def data_dir() -> Path:
    p = Path(str(resources.files("clbrdf"))) / "data" / "published_fits"
    if not p.is_dir():
        raise FileNotFoundError(f"preset data not found at {p}")
    return p


_LINE = re.compile(r"^\s*([^=#\s]+)\s*=\s*Aggregate\((.*)\)\s*$")
_TERM = re.compile(r"(\w+)\(([^()]*)\)")
_KV = re.compile(r"(\w+)\s*=\s*(\[[^\]]*\]|[^,\s]+)")


def _value(text: str):
    text = text.strip()
    if text.startswith("["):
        return [float(x) for x in text.strip("[]").split(",")]
    return float(text)


def parse_fit_line(line: str) -> dict | None:
    """``name = Aggregate(Lambertian(albedo = [r, g, b]), Model(key = value, ...))`` ->
    ``{"name": name, "Lambertian": {"albedo": [...]}, "Model": {...}}``; None for comments."""
    m = _LINE.match(line)
    if not m:
        return None
    out: dict = {"name": m.group(1)}
    for term, args in _TERM.findall(m.group(2)):
        out[term] = {k: _value(v) for k, v in _KV.findall(args)}
    return out


@lru_cache(maxsize=None)
def load(source: str) -> dict[str, dict]:
    """Material name -> its fit (a parsed .fit line, or a .csv row with numbers as floats)."""
    path = data_dir() / source
    fits: dict[str, dict] = {}
    if path.suffix == ".fit":
        for line in path.read_text().splitlines():
            if line.lstrip().startswith("#"):
                continue
            d = parse_fit_line(line)
            if d:
                fits[d["name"]] = d
    elif path.suffix == ".csv":
        with path.open(newline="") as f:
            for row in csv.DictReader(f):
                d = {}
                for k, v in row.items():
                    try:
                        d[k] = float(v)
                    except ValueError:
                        d[k] = v
                fits[row["name"]] = d
    else:
        raise ValueError(f"unknown preset file type: {source}")
    return fits


def source_label(source: str) -> str:
    """Short name of a source: the E1/E2 metric of Löw's fits, else the file stem."""
    m = re.search(r"_(E\d)\.", source)
    return m.group(1) if m else Path(source).stem


@lru_cache(maxsize=None)
def sources() -> dict[str, list[tuple[str, object]]]:
    """Model name -> [(fit file, to_params)], from the model modules' PRESETS."""
    import importlib
    import pkgutil
    out: dict[str, list] = {}
    for info in pkgutil.iter_modules(models.__path__):
        mod = importlib.import_module(f"{models.__name__}.{info.name}")
        table = getattr(mod, "PRESETS", None)
        if not table:
            continue
        specs = getattr(mod, "SPECS", ())
        for source, entry in table.items():
            if callable(entry):
                if len(specs) != 1:
                    raise RuntimeError(f"clbrdf.models.{info.name}.PRESETS[{source!r}] must name its "
                                       "model: the module defines several")
                entry = (specs[0].name, entry)
            for name, fn in (entry if isinstance(entry, list) else [entry]):
                out.setdefault(name, []).append((source, fn))
    return out


def materials(model: str) -> list[str]:
    """The materials with a fit for ``model`` (in its default source)."""
    src = sources().get(model)
    if not src:
        return []
    return sorted(load(src[0][0]))


def get(model: str, material: str) -> Preset:
    """The preset ``material`` (or ``material:source``) of ``model``: from the model's default
    source, or the first of its other sources that has the material."""
    src = sources().get(model)
    if not src:
        have = ", ".join(sorted(sources())) or "none"
        raise ParameterError(f"model {model} has no presets; models with presets: {have}")
    name, _, which = material.partition(":")
    if which:
        pick = [s for s in src if which in (s[0], source_label(s[0]), Path(s[0]).stem)]
        if not pick:
            raise ParameterError(f"preset source {which!r} is not valid for {model}: choose one of "
                                 f"{', '.join(source_label(s) for s, _ in src)}")
        source, fn = pick[0]
    else:      # the default source, else the first other source that has the material
        source, fn = next(((s, f) for s, f in src if name in load(s)), src[0])
    fits = load(source)
    if name not in fits:
        close = [m for m in fits if name.lower() in m.lower()][:8]
        hint = f"; similar: {', '.join(close)}" if close else ""
        raise ParameterError(f"preset {name!r} is not a material of {model} ({source}): "
                             f"`clbrdf models {model} --presets` lists the {len(fits)} materials{hint}")
    options, params = fn(fits[name])
    return Preset(name, model, source, dict(options), dict(params))


def applied(model: str, preset: str | None, params: dict, channels: int | None = None):
    """(params, channels) with preset ``preset`` of ``model`` under ``params`` (which override
    it): an RGB fit, so channels 3 unless given; without a preset, as given (channels 1)."""
    if preset is None:
        return dict(params), channels or 1
    p = get(model, preset)
    return {**p.options, **p.params, **params}, 3 if channels is None else channels


def summary() -> dict[str, dict]:
    """Model -> {"sources": [{file, label, attribution, materials}], "materials": [...]}."""
    out = {}
    for model, src in sorted(sources().items()):
        out[model] = {"sources": [{"file": s, "label": source_label(s), "attribution": ATTRIBUTION.get(s, s),
                                   "materials": len(load(s))} for s, _ in src],
                      "materials": materials(model)}
    return out
