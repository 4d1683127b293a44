"""The model contract, for every registered model: a displayed default is the real one."""
import numpy as np
import pytest

import clbrdf
from clbrdf.models import MODELS

WO = np.array([[0.0, 0.6, 0.8], [0.3, 0.0, 0.953939], [0.95, 0.1, 0.295804]])
WI = np.array([[0.0, -0.6, 0.8], [-0.5, 0.2, 0.842615], [0.1, 0.0, 0.994987]])


@pytest.mark.parametrize("name", list(MODELS))
def test_displayed_defaults_are_the_real_ones(name):
    """Passing each parameter of the default configuration at its displayed default changes
    nothing; a parameter whose default is computed from others (sgd_bagher's kap: passing the
    old displayed 1 changed E(0.5) from 0.74 to 0.11) is not used until given and says so."""
    spec = MODELS[name]
    base = clbrdf.Model(name, precision="double")
    f0 = base.eval(WO, WI)
    for p in spec.params:
        if p.computed:
            assert p.name not in base.config.param_names, p.name
            continue
        if p.name not in base.config.param_names:
            continue
        m = clbrdf.Model(name, precision="double", **{p.name: p.default})
        np.testing.assert_array_equal(m.eval(WO, WI), f0, err_msg=p.name)


def test_models_cli_shows_computed_default():
    from clbrdf.cli import main
    import contextlib
    import io
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["models", "sgd_bagher"]) == 0
    line = next(ln for ln in buf.getvalue().splitlines() if ln.strip().startswith("kap "))
    assert "default computed" in line and "1 / (alpha Gamma(1-p, alpha))" in line


def test_argument_order_is_wo_wi_everywhere():
    """(wo, wi) in Model, in every reference, and by keyword; pdf(wo, wi) is the density of wi
    given wo: for a GGX lobe sampled by visible normals pdf(wo, wi) != pdf(wi, wo)."""
    import inspect
    from clbrdf.ref import Reference, reference
    for fn in (clbrdf.Model.eval, clbrdf.Model.pdf, Reference.eval, Reference.pdf):
        assert list(inspect.signature(fn).parameters)[1:3] == ["wo", "wi"], fn
    m = clbrdf.Model("ggx", alpha=0.3, precision="double")
    np.testing.assert_array_equal(m.eval(wi=WI, wo=WO), m.eval(WO, WI))
    ref = reference(m)
    np.testing.assert_allclose(m.pdf(WO, WI), ref.pdf(WO, WI), rtol=1e-12)
    assert not np.allclose(m.pdf(WO, WI), m.pdf(WI, WO), rtol=1e-3)


def test_hooks_are_methods_a_subclass_overrides():
    """Each hook (resolve, anisotropic, mu_kinks, energy_bound, deltas) is a method of the
    description: given as a function or overridden in a subclass; a configuration that is not a
    Resolved value is refused, naming the model."""
    import dataclasses

    from clbrdf.models.spec import ModelSpec, Resolved
    base = MODELS["ward"]

    class Tilted(ModelSpec):
        def resolve(self, opts, given):
            r = super().resolve(opts, given)
            return dataclasses.replace(r, defines=r.defines + (("TILTED", "1"),))

        def energy_bound(self, cfg, values, mu):
            return np.full(np.shape(mu), 2.0)

    spec = Tilted(**{f.name: getattr(base, f.name) for f in dataclasses.fields(ModelSpec)})
    cfg, values = spec.configure(alpha_x=0.1, alpha_y=0.3)
    assert ("TILTED", "1") in cfg.defines and spec.anisotropic(cfg, values)
    assert np.all(spec.energy_bound(cfg, values, np.array([0.5, 1.0])) == 2.0)
    assert np.all(base.energy_bound(cfg, values, np.array([0.5, 1.0])) == 1.0)

    class Loose(ModelSpec):
        def resolve(self, opts, given):
            return (), ("alpha_x", "alpha_y", "ks"), {}
    loose = Loose(**{f.name: getattr(base, f.name) for f in dataclasses.fields(ModelSpec)})
    with pytest.raises(TypeError, match="model ward: its configuration is a tuple"):
        loose.configure()
