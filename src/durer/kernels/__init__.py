"""Numba kernels: the only code that loops over rays and primitives."""
