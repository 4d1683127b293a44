"""Double-precision NumPy references of the models, one module per model family, written from the papers independently of the kernels."""
