"""``clbrdf.Model``: a model configuration on a device, evaluated, sampled and its densities
computed in bulk. Arrays in, arrays out: parameters and directions broadcast as in NumPy.
"""
from __future__ import annotations

import math

import numpy as np

from ..models import get_spec, presets
from ..models.choices import PRECISIONS, WIDTHS
from ..models.spec import ParameterError, check_choice, check_directions, check_int
from ..runtime.bound import Bound
from ..runtime.device import Device, get_device
from ..runtime.launch import kernel, ndrange, seed_words, working_width



class Model(Bound):
    """A model configuration on a device.

    >>> m = Model("ggx", alpha=0.3, fresnel="schlick", f0=0.04)
    >>> m.eval(wo, wi)                  # BRDF values, 1/sr
    >>> wi, weight, pdf = m.sample(wo, seed=1)

    Parameters may be arrays; they broadcast with the directions. ``precision`` is ``single`` or
    ``double``; ``width`` the lanes per work-item (default: 16 single / 8 double on a CPU, 1 on
    a GPU); ``device`` a selector (see ``clbrdf.runtime.device``). ``channels=3`` makes the model RGB:
    parameters marked per channel take a trailing axis of 3 (``kd=[0.2, 0.3, 0.4]``), and values,
    sample weights and albedos get a trailing axis of 3.
    """

    def __init__(self, name: str, *, precision: str = "single", device=None, width: int | None = None,
                 channels: int | None = None, preset: str | None = None, **params):
        self.spec = get_spec(name)
        # a published fit (clbrdf.presets); params override it
        self.preset = None if preset is None else presets.get(self.spec.name, preset)
        params, channels = presets.applied(self.spec.name, preset, params, channels)
        config, params = self.spec.configure(channels=channels, **params)
        check_choice("precision", precision, PRECISIONS)
        dev: Device = get_device(device)
        width = working_width(dev, precision) if width is None else width
        if isinstance(width, bool) or width not in WIDTHS:
            raise ParameterError(f"width={width!r} is not valid: choose one of 1, 2, 4, 8, 16")
        super().__init__(config, params, precision, dev, width)

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def anisotropic(self) -> bool:
        """Whether E(wo) may depend on the azimuth of wo (see ModelSpec.anisotropic)."""
        return self.spec.anisotropic(self.config, self.params)

    @property
    def options(self) -> dict:
        return dict(self.config.options)

    def describe(self) -> dict:
        """Model name, preset, options and parameters (scalars as floats, arrays as lists)."""
        pre = {"preset": f"{self.preset.material} ({self.preset.source})"} if self.preset else {}
        return {"model": self.name, **pre, **self.options,
                **{k: (v.item() if v.ndim == 0 else v.tolist()) for k, v in self.params.items()}}

    def __repr__(self):
        d = ", ".join(f"{k}={v}" for k, v in self.describe().items() if k != "model")
        return f"Model({self.name!r}, {d}, precision={self.precision!r}, width={self.width})"

    # ---- public API ----
    def eval(self, wo, wi) -> np.ndarray:
        """BRDF value f(wo, wi) in 1/sr (shape (..., 3) for an RGB model); 0 where either
        direction is below the horizon, unless the model transmits (``spec.transmits``: a BSDF
        over the whole sphere)."""
        wo = check_directions("wo", wo, allow_below=True)
        wi = check_directions("wi", wi, allow_below=True)
        shape = self.points_shape(wo, wi)
        (f,) = self.batch("eval_batch", shape, [np.moveaxis(wo, -1, 0), np.moveaxis(wi, -1, 0)],
                           [self.channels])
        return self.channel_axis(f)

    def pdf(self, wo, wi) -> np.ndarray:
        """Density (1/sr) of wi under the model's sampler, given wo."""
        wo = check_directions("wo", wo, allow_below=True)
        wi = check_directions("wi", wi, allow_below=True)
        shape = self.points_shape(wo, wi)
        (p,) = self.batch("pdf_batch", shape, [np.moveaxis(wo, -1, 0), np.moveaxis(wi, -1, 0)], [1])
        return p[0]

    def sample(self, wo, u=None, *, seed: int = 0, qmc: bool = False):
        """Importance-sample wi given wo. ``u``: uniform numbers of shape (..., 4); if omitted they
        are drawn from the library's generator keyed by (seed, index). Returns (wi, weight, pdf),
        weight = f |cos(theta_i)| / pdf (0 for a sample below the horizon of a BRDF; (..., 3) for
        RGB). A model that transmits takes wo on either side and returns wi on either side."""
        wo = check_directions("wo", wo, allow_below=self.spec.transmits)
        shape = self.points_shape(wo) if u is None else self.points_shape(wo, np.asarray(u)[..., :3])
        if u is None:
            u = self.random(math.prod(shape), seed=seed, qmc=qmc).reshape(shape + (4,))
        u = np.asarray(u, dtype=np.float64)
        if u.shape[-1:] != (4,):
            raise ParameterError(f"u must have shape (..., 4), got {u.shape}")
        if np.any(~(u >= 0) | ~(u < 1)):
            raise ParameterError("u must lie in [0, 1)")
        if self.dtype == np.float32:            # 1 - 1e-9 would round to 1.0f
            u = np.minimum(u, float(np.nextafter(np.float32(1), np.float32(0))))
        wi, weight, pdf = self.batch("sample_batch", shape,
                                      [np.moveaxis(wo, -1, 0), np.moveaxis(u, -1, 0)],
                                      [3, self.channels, 1])
        return np.moveaxis(wi, 0, -1), self.channel_axis(weight), pdf[0]

    def random(self, n: int, *, seed: int = 0, point: int = 0, stream: int = 0, qmc: bool = False):
        """(n, 4) uniform numbers of sample indices 0..n-1 from the kernels' generator
        (Philox4x32-10, or Owen-scrambled Sobol with ``qmc``)."""
        import pyopencl as cl
        n = check_int("n", n, 0, 2**32 - 1)
        point = check_int("point", point, 0, 2**32 - 1)
        stream = check_int("stream", stream, 0, 2**32 - 1)
        w = self.width
        n_pad = max(w, -(-n // w) * w)
        prog = self.program(part="random", rng="sobol" if qmc else "philox")
        buf = cl.Buffer(self.device.context, cl.mem_flags.WRITE_ONLY, 4 * n_pad * np.dtype(self.dtype).itemsize)
        lo, hi = seed_words(seed)
        kernel(prog.program, "random_batch")(self.device.queue, *ndrange(n_pad // w, self.device), np.uint64(n_pad), np.uint32(point),
                          np.uint32(stream), lo, hi, buf)
        out = np.empty((4, n_pad), dtype=self.dtype)
        cl.enqueue_copy(self.device.queue, out, buf)
        return out[:, :n].T.copy()


def model(name: str, **kw) -> Model:
    """Shorthand for ``Model(name, **kw)``."""
    return Model(name, **kw)
