"""The per-model parts of the documentation, generated from the model descriptions
(clbrdf/models/*.py): the table of every model in docs/models.md (name, what, paper and
equations, options, page) and the Models section of the site's navigation (mkdocs.yml: the
overview, each model page in the order of the models, then "Adding a model"). A new model's
description names its page (``ModelSpec.page``) and nothing else is edited by hand.

    python scripts/model_docs.py           # rewrite both
    python scripts/model_docs.py --check   # exit 1 if either is out of date (tests/test_docs.py)
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
BEGIN = "<!-- generated from the model descriptions by scripts/model_docs.py: do not edit -->"
END = "<!-- end of the generated table -->"
OVERVIEW = "models.md"


def _specs():
    from clbrdf.models import MODELS
    return MODELS


def _check_pages(specs) -> None:
    for name, s in specs.items():
        if not s.page:
            raise SystemExit(f"model {name}: its description names no page (ModelSpec.page)")
        path, _, anchor = s.page.partition("#")
        if not (DOCS / path).is_file():
            raise SystemExit(f"model {name}: page {s.page} is not a file of docs/")
        if anchor and anchor not in {_slug(h) for h in _headings(DOCS / path)}:
            raise SystemExit(f"model {name}: page {s.page}: no heading with that anchor")


def _headings(path: Path) -> list:
    return [ln.lstrip("#").strip() for ln in path.read_text().splitlines() if ln.startswith("#")]


def _slug(heading: str) -> str:
    """mkdocs' (Python-Markdown toc) anchor of a heading."""
    s = re.sub(r"[^\w\s-]", "", heading.replace("`", "")).strip().lower()
    return re.sub(r"[\s-]+", "-", s)


def models_table(specs) -> str:
    rows = ["| model | what | paper and equations | options | page |", "|---|---|---|---|---|"]
    for name, s in specs.items():
        path, _, anchor = s.page.partition("#")
        link = f"[below](#{anchor})" if path == OVERVIEW else f"[{path}]({path})"
        opts = ", ".join(f"`{o.name}`" for o in s.options) or "none"
        rows.append(f"| `{name}` | {s.title} | {s.reference} | {opts} | {link} |")
    return "\n".join(rows)


def nav_block(specs) -> str:
    pages = [OVERVIEW]
    for s in specs.values():
        path = s.page.partition("#")[0]
        if path not in pages:
            pages.append(path)
    lines = ["  - Models:", f"      - Overview: {OVERVIEW}"]
    for path in pages[1:]:
        title = re.split(r"[:(]", _headings(DOCS / path)[0])[0].replace("`", "").strip()
        lines.append(f"      - {title}: {path}")
    lines.append("      - Adding a model: adding-a-model.md")
    return "\n".join(lines) + "\n"


def _replace_models_table(text: str, table: str) -> str:
    a, b = text.index(BEGIN), text.index(END)
    return text[:a] + BEGIN + "\n" + table + "\n" + text[b:]


def _replace_nav(text: str, block: str) -> str:
    a = text.index("  - Models:\n")
    b = text.index("      - Adding a model: adding-a-model.md\n", a)
    b += len("      - Adding a model: adding-a-model.md\n")
    return text[:a] + block + text[b:]


def main(argv) -> int:
    specs = _specs()
    _check_pages(specs)
    models_md, mkdocs = DOCS / OVERVIEW, ROOT / "mkdocs.yml"
    want = {models_md: _replace_models_table(models_md.read_text(), models_table(specs)),
            mkdocs: _replace_nav(mkdocs.read_text(), nav_block(specs))}
    stale = [p for p, t in want.items() if p.read_text() != t]
    if "--check" in argv:
        for p in stale:
            print(f"{p.relative_to(ROOT)} is out of date: python scripts/model_docs.py",
                  file=sys.stderr)
        return 1 if stale else 0
    for p in stale:
        p.write_text(want[p])
        print(f"wrote {p.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
