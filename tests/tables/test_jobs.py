"""One validated job per table product (clbrdf.tables.jobs): every bad argument is refused by the
job's constructor, naming its parameter, before anything is built; a job survives its JSON; a
file's provenance is its job, and running that job again gives the file's numbers bit for bit."""
import dataclasses

import numpy as np
import pytest

from clbrdf import load_tables, save_tables
from clbrdf.models.spec import ParameterError
from clbrdf.tables.jobs import Job, layout_job, ltc_job, run_job, table_job

GRID = {"mu": "0.1:1:3", "r": "0.2:1:2"}
JOBS = {
    "table": lambda: table_job("ggx", GRID, samples=256, f0=0.4),
    "table-rgb-preset": lambda: table_job("beckmann", {"mu": "0.2,0.9"}, samples=64,
                                          preset="alum-bronze"),
    "table-quadrature": lambda: table_job("ggx", {"mu": "0.3,1"}, estimator="quadrature",
                                          tol=1e-4, alpha=0.3),
    "table-split-target": lambda: table_job("ggx", GRID, samples=64, split=True, qmc=True,
                                            target_stderr=1e-3),
    "layout": lambda: layout_job("threejs", samples=64),
    "layout-default": lambda: layout_job("cycles"),
    "ltc-layout": lambda: ltc_job(layout="cycles_sheen", magnitude_tol=1e-4),
    "ltc-grid": lambda: ltc_job("ggx", {"mu": "0.2,0.9", "r": "0.3,0.6"}, form="zeltner"),
}


@pytest.mark.smoke
@pytest.mark.parametrize("case", JOBS)
def test_a_job_survives_its_json(case):
    job = JOBS[case]()
    assert Job.from_json(job.to_json()) == job
    with pytest.raises(dataclasses.FrozenInstanceError):
        job.text = "{}"


BAD = [
    # (constructor, arguments, the parameter the error names)
    (table_job, dict(model="ggx", axes={"mu": "0:1:4"}), "axis"),     # mu = 0 is below the horizon
    (table_job, dict(model="ggx", axes={"mu": "0.1:1:4", "r": "0:2:3"}), "axis"),
    (table_job, dict(model="ggx", axes={"mu": "0.1:1:4"}, f0=2.0), None),
    (table_job, dict(model="ggx", axes={"mu": "0.1:1:4"}, samples=1), "samples"),
    (table_job, dict(model="ggx", axes={"mu": "0.1:1:4"}, estimator="nope"), "estimator"),
    (table_job, dict(model="ggx", axes={"mu": "0.1:1:4"}, tol=1e-3), "tol"),
    (table_job, dict(model="ggx", axes={"mu": "0.1:1:4"}, estimator="quadrature",
                     target_stderr=1e-3), "target_stderr"),
    (table_job, dict(model="ggx", axes={"mu": "0.1:1:4"}, max_samples=1 << 20), "max_samples"),
    (table_job, dict(model="ggx", axes={"mu": "0.1:1:4"}, precision="half"), "precision"),
    (table_job, dict(model="ggx", axes={"mu": "0.1:1:4"}, width=3), "width"),
    (layout_job, dict(layout="threejs", samples=64, match_published=True), "samples"),
    (layout_job, dict(layout="threejs", only="nope"), "only"),
    (ltc_job, dict(layout="threejs", form="zeltner"), "layout"),
    (ltc_job, dict(layout="nope"), "layout"),
    (ltc_job, dict(model="ggx_dielectric", axes={"mu": "0.2,0.9"}), "model"),
    (ltc_job, dict(model="ggx", axes={"mu": "0.2,0.9"}, samples=100), "samples"),
    (ltc_job, dict(model="ggx", axes={"mu": "0.2,0.9"}, form="round"), "form"),
    (ltc_job, dict(model="ggx", axes={"mu": "0.2,0.9"}, preset="gold"), "preset"),
    (ltc_job, dict(model="ggx", axes={"mu": "0.2,0.9"}, magnitude_tol=0.5), "magnitude_tol"),
]


@pytest.mark.smoke
@pytest.mark.parametrize("make, kw, param", BAD,
                         ids=[f"{m.__name__}-{i}" for i, (m, _, _) in enumerate(BAD)])
def test_bad_arguments_are_refused_by_the_job(make, kw, param):
    with pytest.raises(ParameterError) as e:
        make(**kw)
    if param is not None:
        assert e.value.param == param or param in str(e.value), (e.value.param, str(e.value))


def test_a_files_provenance_reruns_to_its_numbers(tmp_path):
    """The .npz's meta["job"] is the job; running it again gives the stored arrays bit for bit,
    and so does the library's albedo_table with the same arguments."""
    from clbrdf import albedo_table
    job = table_job("ggx", GRID, samples=512, qmc=True, f0=0.4, seed=3)
    tables = run_job(job)
    save_tables(tables, tmp_path / "t.npz", chart=False)
    back = load_tables(tmp_path / "t.npz")["E"]
    again = run_job(Job.from_json(back.meta["job"]))["E"]
    direct = albedo_table("ggx", GRID, samples=512, qmc=True, f0=0.4, seed=3)
    for t in (again, direct):
        np.testing.assert_array_equal(t.raw, back.raw)
        np.testing.assert_array_equal(t.stderr, back.stderr)
    assert Job.from_json(back.meta["job"]) == job
