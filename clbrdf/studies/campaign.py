"""The skeleton of the studies' campaigns (``clbrdf accuracy``, ``clbrdf ladder``, ``clbrdf
stability``): cases (the models), each measured into rows of one or more CSV tables and a
chart; then the tables, a chart per model and a README.md summary are written to the campaign's
folder, all together once everything is measured (clbrdf.tables' staged writes: a kill at any
moment leaves the old files or the new ones). The rows of the models not measured this time stay
from the folder's earlier tables (and their charts), so that a run of a few models updates
them in place (``--models``)."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from ..tables.outputs import csv_rows, csv_text, write_together


@dataclass(frozen=True)
class CsvTable:
    """One CSV table of a campaign: its columns, and how its rows are read back (numbers as
    numbers)."""
    fields: tuple
    read: Callable = csv_rows          # path -> rows


@dataclass(frozen=True)
class Campaign:
    """``measure(model) -> ({CSV name: rows}, chart PNG bytes)``; ``summary(every row by CSV
    name, command, seconds, models measured) -> README.md text``; ``order``: the models'
    order of the tables' rows (else the kept rows, then the measured ones)."""
    tables: dict                       # CSV name -> CsvTable
    measure: Callable
    summary: Callable
    order: tuple = field(default=())

    def run(self, models, out, command: str, progress=None) -> Path:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        kept = {k: [r for r in t.read(out / k) if r["model"] not in models]
                if (out / k).exists() else [] for k, t in self.tables.items()}
        charts = {}
        for name in models:
            rows, charts[name] = self.measure(name)
            for k in self.tables:
                kept[k] += rows.get(k, [])
            if progress:
                progress(name)
        if self.order:
            rank = {m: i for i, m in enumerate(self.order)}
            for rows in kept.values():
                rows.sort(key=lambda r: rank.get(r["model"], len(rank)))
        files = {out / f"{n}.png": png for n, png in charts.items()}
        files.update({out / k: csv_text(kept[k], t.fields) for k, t in self.tables.items()})
        files[out / "README.md"] = self.summary(kept, command, time.perf_counter() - t0, models)
        write_together(files)
        return out


def measured_note(rows, measured) -> str:
    """The summary's note where a run measured only some of its rows' models ('' where it
    measured them all)."""
    every = dict.fromkeys(r["model"] for r in rows)
    if measured is None or set(measured) >= set(every):
        return ""
    return f"this run measured {', '.join(measured)}; the other models' rows are an earlier run's"


def png(figure, **kw) -> bytes:
    """A campaign chart's PNG bytes (``kw``: savefig's)."""
    import io
    buf = io.BytesIO()
    figure.savefig(buf, format="png", **kw)
    return buf.getvalue()
