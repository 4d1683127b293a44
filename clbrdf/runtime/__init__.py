"""The runtime: OpenCL devices (``device``), kernel programs built and cached (``build``), a
model configuration bound to a device (``bound``), launches (``launch``), and the drivers of the
Monte Carlo albedo (``albedo``) and of the deterministic quadrature (``quadrature``).

Below it: the model descriptions (clbrdf.models) and the kernels (clbrdf.kernels); above it:
the public API (clbrdf.api).
"""
