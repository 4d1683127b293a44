"""Optical constants of the conductor presets (clbrdf/data/published_fits/metals_rgb.csv) from
the refractiveindex.info database (CC0; github.com/polyanskiy/refractiveindex.info-database):
n and k at the R, G, B wavelengths 0.645, 0.526, 0.444 um (docs/models/microfacet.md), linear
between the tabulated wavelengths; the tabulated rows from 0.40 to 0.70 um go to
tests/data/metals_nk.csv, against which tests/models/test_metals.py checks the presets.

    python scripts/metals.py PATH_TO_THE_DATABASE_CHECKOUT [COMMIT]
"""
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RGB_UM = (0.645, 0.526, 0.444)
METALS = {    # preset name: (file under database/data/main, citation)
    "gold": ("Au/nk/Johnson.yml", "Johnson & Christy 1972, Phys. Rev. B 6, 4370"),
    "silver": ("Ag/nk/Johnson.yml", "Johnson & Christy 1972, Phys. Rev. B 6, 4370"),
    "copper": ("Cu/nk/Johnson.yml", "Johnson & Christy 1972, Phys. Rev. B 6, 4370"),
    "chromium": ("Cr/nk/Johnson.yml", "Johnson & Christy 1974, Phys. Rev. B 9, 5056"),
    "aluminium": ("Al/nk/Rakic.yml", "Rakic 1995, Appl. Opt. 34, 4755"),
}


def tabulated(path: Path) -> np.ndarray:
    """(wavelength um, n, k) rows of a 'tabulated nk' block."""
    rows, inside = [], False
    for line in path.read_text().splitlines():
        if line.strip().startswith("data: |"):
            inside = True
            continue
        if inside:
            parts = line.split()
            if len(parts) != 3:
                break
            rows.append([float(x) for x in parts])
    return np.array(rows)


def main():
    db = Path(sys.argv[1])
    commit = sys.argv[2] if len(sys.argv) > 2 else "unknown"
    head = (f"# refractiveindex.info database (CC0 1.0, github.com/polyanskiy/refractiveindex.info-"
            f"database at {commit}); written by scripts/metals.py\n")
    # the presets' file has no comment lines (csv.DictReader); its provenance is in SOURCES.md
    rgb = ["name,eta_r,eta_g,eta_b,k_r,k_g,k_b,reference\n"]
    nk = [head, "name,wavelength_um,n,k\n"]
    for name, (rel, cite) in METALS.items():
        t = tabulated(db / "database" / "data" / "main" / rel)
        eta = [np.interp(w, t[:, 0], t[:, 1]) for w in RGB_UM]
        k = [np.interp(w, t[:, 0], t[:, 2]) for w in RGB_UM]
        rgb.append(f"{name}," + ",".join(f"{v:.6g}" for v in eta + k)
                   + f",{cite.replace(', ', ' ')} ({rel})\n")
        for w, n_, k_ in t[(t[:, 0] >= 0.40) & (t[:, 0] <= 0.70)]:
            nk.append(f"{name},{w:g},{n_:g},{k_:g}\n")
    (ROOT / "clbrdf/data/published_fits/metals_rgb.csv").write_text("".join(rgb))
    (ROOT / "tests/data/metals_nk.csv").write_text("".join(nk))


if __name__ == "__main__":
    main()
