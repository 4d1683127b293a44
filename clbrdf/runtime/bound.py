"""A model configuration bound to a device, a precision and a width: its programs, and the
structure-of-arrays blocks of parameters and directions that every kernel reads.

``clbrdf.Model`` is one (with validation and the public methods on top); the drivers in
``albedo`` and ``quadrature`` and the timing of ``clbrdf.studies.ladder`` use only what is here.
"""
from __future__ import annotations

import math

import numpy as np

from ..models.spec import Config, ParameterError
from . import build
from .device import Device
from .launch import kernel, ndrange


def dtype_of(precision: str):
    return np.float32 if precision == "single" else np.float64


class Bound:
    """``config`` (models.spec.Config) with its validated ``params`` on ``device``."""

    def __init__(self, config: Config, params: dict, precision: str, device: Device, width: int):
        self.config, self.params = config, params
        self.precision, self.device, self.width = precision, device, width
        self.dtype = dtype_of(precision)

    @property
    def channels(self) -> int:
        return self.config.channels

    def program(self, **kw):
        return build.get_program(self.device, self.config, self.precision, self.width, **kw)

    def soa(self, shape, arrays, n_pad):
        """Stack arrays broadcast to shape as rows of a (len, n_pad) structure-of-arrays block."""
        out = np.zeros((len(arrays), n_pad), dtype=self.dtype)
        n = math.prod(shape)
        for j, a in enumerate(arrays):
            out[j, :n] = np.broadcast_to(a, shape).reshape(-1)
            out[j, n:] = out[j, n - 1] if n else 0    # pad with a valid value
        return out

    def param_rows(self):
        """The parameter block's rows: one per scalar parameter, one per channel of a spectral one."""
        rows = []
        for k in self.config.param_names:
            v = self.params[k]
            rows += [v[..., c] for c in range(self.channels)] if k in self.config.spectral and \
                self.channels > 1 else [v]
        return rows

    def point_params(self, shape, i0: int, i1: int) -> dict:
        """The parameters at flat points i0 .. i1 of ``shape`` (broadcast, then sliced): a part
        of a computation, keyed by its first point (``run_albedo``'s ``point0``)."""
        out = {}
        for k, v in self.params.items():
            per = (self.channels,) if k in self.config.spectral and self.channels > 1 else ()
            a = np.broadcast_to(np.asarray(v), tuple(shape) + per).reshape((-1,) + per)
            out[k] = np.ascontiguousarray(a[i0:i1])
        return out

    def param_block(self, shape, n_pad):
        return self.soa(shape, self.param_rows(), n_pad)

    def points_shape(self, *dirs):
        """The broadcast shape of the parameters and the directions (arrays (..., 3))."""
        shapes = [r.shape for r in self.param_rows()] + [d.shape[:-1] for d in dirs]
        try:
            return np.broadcast_shapes(*shapes)
        except ValueError as e:
            raise ParameterError(f"parameters and directions do not broadcast: {e}") from None

    def channel_axis(self, a):
        """(channels, ...) -> (...) for one channel, (..., channels) otherwise."""
        return a[0] if self.channels == 1 else np.moveaxis(a, 0, -1)

    def batch(self, kernel_name: str, shape, inputs: list, outputs: list):
        launch, fetch = self.batch_prepare(kernel_name, shape, inputs, outputs)
        launch()
        return fetch()

    def batch_prepare(self, kernel_name: str, shape, inputs: list, outputs: list):
        """Device buffers of one batch call and two closures: ``launch()`` runs the kernel and
        waits for it (repeatable: clbrdf.studies.ladder times it alone), ``fetch()`` reads the
        outputs."""
        import pyopencl as cl
        n = math.prod(shape)
        w = self.width
        n_pad = max(w, -(-n // w) * w)
        ctx, q = self.device.context, self.device.queue
        mf = cl.mem_flags
        bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=self.param_block(shape, n_pad))]
        for arr in inputs:     # each (k, ...) -> SoA (k, n_pad)
            bufs.append(cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                                  hostbuf=self.soa(shape, list(arr), n_pad)))
        host_out = [np.empty((k, n_pad), dtype=self.dtype) for k in outputs]
        out_bufs = [cl.Buffer(ctx, mf.WRITE_ONLY, h.nbytes) for h in host_out]
        prog = self.program(part="batch")
        knl = kernel(prog.program, kernel_name)

        def launch():
            knl(q, *ndrange(n_pad // w, self.device), bufs[0], prog.tables, *bufs[1:],
                np.uint64(n_pad), *out_bufs)
            q.finish()

        def fetch():
            for h, b in zip(host_out, out_bufs):
                cl.enqueue_copy(q, h, b)
            q.finish()
            return [h[:, :n].reshape((h.shape[0],) + shape) for h in host_out]
        return launch, fetch
