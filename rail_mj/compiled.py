"""numba's kernels compiled once per installation into shared libraries, loaded without numba.

Importing numba and loading its cached functions costs most of a short command (about 0.9 s
of a 1.1 s `rail-mj run` of 100 m). So the kernels a run steps and summarises with are built,
the first time one is needed, into a shared library in the package's cache folder
(`rail_mj.files.cache_folder`, named by the package's sources): numba compiles each kernel
(a cfunc), llvmlite emits its machine code for this CPU with everything but the kernel itself
made private and dropped where unused, and the C compiler links it with a few lines of C that
are the library's entry points. Later processes load it with ctypes: numba is not imported.

A kernel must stand alone to be built so: no allocation (numba's runtime is not in the
library) and nothing called but C's maths library, which `load` checks, refusing the build
(and its caller falls back on numba in the process) otherwise.

Where no C compiler is found (gcc, or $CC) or no folder can be written, `load` returns None:
the caller compiles its kernels with numba in the process, as before the library existed.

Example (C alone, no kernel):

    >>> library = load("example", "", "double twice(double x) { return 2.0 * x; }")
    >>> import ctypes
    >>> library.twice.restype, library.twice.argtypes = ctypes.c_double, (ctypes.c_double,)
    >>> library.twice(1.5)
    3.0
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
from collections.abc import Callable
from pathlib import Path

from rail_mj import files

# What a kernel's machine code may call once it stands alone: C's maths library (and numba's
# release of an array's memory, which `_RUNTIME` defines and a kernel never reaches).
LIBM = frozenset(
    [
        "acos",
        "acosh",
        "asin",
        "asinh",
        "atan",
        "atan2",
        "atanh",
        "cbrt",
        "ceil",
        "copysign",
        "cos",
        "cosh",
        "erf",
        "erfc",
        "exp",
        "exp2",
        "expm1",
        "fabs",
        "floor",
        "fma",
        "fmax",
        "fmin",
        "fmod",
        "hypot",
        "ldexp",
        "lgamma",
        "log",
        "log10",
        "log1p",
        "log2",
        "nextafter",
        "pow",
        "round",
        "sin",
        "sincos",
        "sinh",
        "sqrt",
        "tan",
        "tanh",
        "tgamma",
        "trunc",
    ]
)

_RUNTIME = """
/* numba's reference counting calls this when the last reference to an array's memory goes. A
   kernel's arrays own none (views of memory its caller passes, or of its own stack: `load`
   refuses a kernel that allocates), so it is never called. */
void NRT_MemInfo_call_dtor(void *meminfo) { (void)meminfo; }
"""

# numba's status codes of a compiled function (numba.core.callconv): returned, returned None.
STATUS_OK = (0, -2)


class BuildError(Exception):
    """The library cannot be built here: the caller uses numba in the process instead."""


def cpu() -> str:
    """What a library's machine code is compiled for: this machine's processor and its features
    (numba's compiler uses them all), so that a cache folder shared between machines (a cluster's
    home directory) never runs one machine's code on another."""
    try:
        with open("/proc/cpuinfo") as f:
            lines = {line for line in f if line.startswith(("model name", "flags", "Features", "CPU part"))}
        return platform.machine() + "".join(sorted(lines))
    except OSError:
        import llvmlite.binding as llvm

        return platform.machine() + llvm.get_host_cpu_name() + llvm.get_host_cpu_features().flatten()


def library_path(name: str, key: str, c_source: str) -> Path:
    """Where the library `name` is kept: named by `key` (what its kernels were compiled with),
    its C source and the CPU, in the cache folder named by the package's sources."""
    digest = hashlib.sha256("\n".join((key, c_source, cpu())).encode()).hexdigest()[:16]
    return files.cache_folder("native") / f"{name}_{digest}.so"


def load(
    name: str, key: str, c_source: str, kernels: Callable[[], dict] | None = None, flags: tuple[str, ...] = ()
) -> ctypes.CDLL | None:
    """The shared library `name`, built the first time: `c_source` linked with the machine code of
    `kernels()` (C name -> numba cfunc, compiled when called; each kernel's body is then the C
    function `<name>` of numba's calling convention, `int <name>(T *result, void **exception,
    args...)` (the value returned written to *result), status in STATUS_OK when it returned;
    numba's C-callable wrapper is dropped). `flags`: the C compiler's own (include folders,
    libraries to link), part of the library's name. None where it cannot be built here (no
    compiler, nowhere to keep it)."""
    path = library_path(name, "\n".join((key, *flags)), c_source)
    for attempt in range(2):
        if attempt or not path.is_file():  # first use for these sources, or a damaged file
            try:
                _build(path, c_source, kernels, flags)
            except Exception:  # no compiler, no room, an llvmlite without this API: numba, here
                return None
        try:
            return ctypes.CDLL(str(path))
        except OSError:
            continue
    return None


def _build(path: Path, c_source: str, kernels: Callable[[], dict] | None, flags: tuple[str, ...] = ()) -> None:
    """Write the library to `path` (beside, then renamed: processes building at once do not clash)."""
    import shutil
    import subprocess
    import tempfile

    compiler = shutil.which(os.environ.get("CC", "gcc"))
    if compiler is None:
        raise BuildError("no C compiler (gcc, or $CC)")
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=path.parent) as work:
        objects = []
        if kernels is not None:
            objects.append(os.path.join(work, "kernels.o"))
            with open(objects[0], "wb") as f:
                f.write(_machine_code(kernels()))
        c_file, shared = os.path.join(work, "library.c"), os.path.join(work, "library.so")
        with open(c_file, "w") as f:
            f.write(c_source + (_RUNTIME if kernels is not None else ""))
        # -ffp-contract=off: no fused multiply-adds, so that C rounds as numba's code does.
        command = [compiler, "-shared", "-fPIC", "-O2", "-ffp-contract=off", "-o", shared, c_file, *objects, *flags]
        command.append("-lm")
        built = subprocess.run(command, check=False, capture_output=True, text=True)
        if built.returncode != 0:
            raise BuildError(f"{os.path.basename(compiler)} could not link {path.name}: {built.stderr.strip()}")
        files.atomic_write(path, Path(shared).read_bytes())


def _machine_code(kernels: dict) -> bytes:
    """One object file of the kernels' bodies, named as `kernels` names them, every other
    function private (and dropped where the bodies do not call it)."""
    import llvmlite.binding as llvm

    module = None
    for c_name, cfunc in kernels.items():
        body = cfunc.native_name.removeprefix("cfunc.")
        part = llvm.parse_assembly(cfunc.inspect_llvm())
        for function in part.functions:
            if function.name == body:
                function.name = c_name
            elif not function.is_declaration:
                function.linkage = "private"
        for variable in part.global_variables:
            if not variable.is_declaration:
                variable.linkage = "private"
        if module is None:
            module = part
        else:
            module.link_in(part)
    assert module is not None
    machine = llvm.Target.from_default_triple().create_target_machine(
        cpu=llvm.get_host_cpu_name(), features=llvm.get_host_cpu_features().flatten(), opt=3, reloc="pic"
    )
    passes = llvm.create_new_module_pass_manager()
    passes.add_global_dead_code_eliminate_pass()
    passes.add_strip_dead_prototype_pass()
    passes.run(module, llvm.create_pass_builder(machine, llvm.create_pipeline_tuning_options()))
    calls = {f.name for f in module.functions if f.is_declaration and not f.name.startswith("llvm.")}
    needs = sorted(calls - LIBM - {"NRT_MemInfo_call_dtor"})
    if needs:
        raise BuildError(f"the compiled kernels call {', '.join(needs)}, which a library of their own cannot provide")
    return machine.emit_object(module)
