"""Tables in the two .npz formats of clbrdf 0.1.0, for tests/tables/test_table_formats.py. Run with the
0.1.0 tree (commit 2cc0bae) first on sys.path:

    git worktree add /tmp/clbrdf-010 2cc0bae
    PYTHONPATH=/tmp/clbrdf-010 .venv/bin/python scripts/write_v010_tables.py tests/data/v0.1.0
"""
import sys
from pathlib import Path
import clbrdf
from clbrdf import tables as plain
out = Path(sys.argv[1]); out.mkdir(parents=True, exist_ok=True)
print("clbrdf from", clbrdf.__file__)
t = clbrdf.albedo_table("ggx", {"mu": [0.2, 0.6, 1.0], "alpha": [0.1, 0.5]}, samples=256, seed=1)
plain.save_table(t, out / "plain.npz")
t = clbrdf.albedo_table("ggx", {"mu": [0.3, 1.0], "r": "0.2:1:2"}, samples=256, channels=3, f0=[0.9, 0.5, 0.1])
plain.save_table(t, out / "plain_rgb.npz")
t = clbrdf.albedo_table("ggx", {"mu": [0.3, 1.0], "alpha": [0.2, 0.4]}, samples=256, split=True,
                        target_stderr=0.02, max_samples=1024)
plain.save_table(t, out / "split_refined.npz")
lay = clbrdf.make_layout("ue5", samples=64)
clbrdf.save_tables(lay, out / "layout_ue5.npz")
for p in sorted(out.iterdir()):
    print(p.name, p.stat().st_size)
