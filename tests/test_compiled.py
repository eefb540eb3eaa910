"""rail_mj.compiled: kernels built into shared libraries once, loaded without numba."""

from __future__ import annotations

import ctypes
import uuid

import pytest

from rail_mj import compiled


def test_without_a_compiler_there_is_no_library_and_the_caller_falls_back(monkeypatch):
    monkeypatch.setenv("CC", "no-such-compiler-here")
    assert compiled.load("test_no_compiler", uuid.uuid4().hex, "int one(void) { return 1; }") is None


def test_a_library_is_built_once_and_found_again():
    key = uuid.uuid4().hex
    library = compiled.load("test_once", key, "int seven(void) { return 7; }")
    assert library is not None and library.seven() == 7
    path = compiled.library_path("test_once", key, "int seven(void) { return 7; }")
    built = path.stat().st_mtime_ns
    again = compiled.load("test_once", key, "int seven(void) { return 7; }")
    assert again is not None and again.seven() == 7
    assert path.stat().st_mtime_ns == built
    path.unlink()


def test_a_kernel_that_allocates_is_refused():
    """numba's runtime is not in a library: a kernel that allocates an array cannot stand alone."""
    import numba
    import numpy as np

    @numba.cfunc(numba.types.float64(numba.types.int64), nopython=True)
    def allocating(n):
        return np.ones(n).sum()

    with pytest.raises(compiled.BuildError, match="NRT_MemInfo_alloc"):
        compiled._machine_code({"allocating_body": allocating})


def test_a_standalone_kernel_is_numbas_body_behind_c():
    import numba

    @numba.cfunc(numba.types.float64(numba.types.float64, numba.types.float64), nopython=True)
    def hypotenuse(a, b):
        return (a * a + b * b) ** 0.5

    # numba's calling convention: the returned value written where its first argument points.
    source = """int hypotenuse_body(double *out, void **e, double a, double b);
double hypotenuse(double a, double b) { void *e = 0; double out = 0.0;
    hypotenuse_body(&out, &e, a, b); return out; }"""
    library = compiled.load("test_kernel", uuid.uuid4().hex, source, lambda: {"hypotenuse_body": hypotenuse})
    assert library is not None
    library.hypotenuse.restype, library.hypotenuse.argtypes = ctypes.c_double, (ctypes.c_double, ctypes.c_double)
    assert library.hypotenuse(3.0, 4.0) == 5.0
