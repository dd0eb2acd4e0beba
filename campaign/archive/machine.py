"""The platform a process computes on: CPU, operating system, Python, and NumPy with the BLAS
library and kernel it calls, as trial attributes (str)."""

from __future__ import annotations

import functools
import platform
from pathlib import Path
from typing import Any, Mapping

import numpy as np

#: the value of a platform attribute this process cannot find out
UNKNOWN = "unknown"
#: the summary :func:`platform_summary` gives a trial written before trials recorded their platform
NOT_RECORDED = "platform not recorded"

# threadpoolctl's ``internal_api`` names, as the libraries spell themselves
_BLAS_NAMES = {"openblas": "OpenBLAS", "mkl": "MKL", "blis": "BLIS", "flexiblas": "FlexiBLAS"}


def _cpu_model() -> str:
    """The CPU's model name (Linux ``/proc/cpuinfo``, else :func:`platform.processor`)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                key, sep, value = line.partition(":")
                if sep and key.strip() in ("model name", "Model", "Hardware") and value.strip():
                    return " ".join(value.split())
    except OSError:
        pass
    return " ".join(platform.processor().split()) or UNKNOWN


def _operating_system() -> str:
    """``Linux glibc 2.36``: the system and, where there is one, its C library (its maths
    library picks code paths by CPU too)."""
    libc, libc_version = platform.libc_ver()
    return " ".join(part for part in (platform.system() or UNKNOWN, libc, libc_version) if part)


def _numpy_blas(build: Mapping[str, Any]) -> tuple[str, str, str]:
    """(library, version, kernel) of the BLAS NumPy calls, as loaded in this process.

    threadpoolctl lists every BLAS library loaded (SciPy brings its own): NumPy's is the one
    inside NumPy's folder or its wheel's ``numpy.libs``, else the one whose version NumPy
    was built against. The kernel is the code path the library picked for this CPU at run
    time (OpenBLAS's core name, ``OPENBLAS_CORETYPE`` when set).
    """
    from threadpoolctl import threadpool_info  # only when a trial is written: 2 ms

    loaded = [lib for lib in threadpool_info() if lib.get("user_api") == "blas"]
    home = Path(np.__file__).resolve().parent

    def numpys(lib: Mapping[str, Any]) -> bool:
        path = Path(str(lib.get("filepath", ""))).resolve()
        return home in path.parents or path.parent == home.parent / f"{home.name}.libs"

    found = ([lib for lib in loaded if numpys(lib)]
             or [lib for lib in loaded if build.get("version") and lib.get("version") == build.get("version")]
             or (loaded if len(loaded) == 1 else []))
    if not found:
        return str(build.get("name") or UNKNOWN), str(build.get("version") or UNKNOWN), UNKNOWN
    lib = found[0]
    api = str(lib.get("internal_api") or "")
    return (_BLAS_NAMES.get(api, api or UNKNOWN), str(lib.get("version") or UNKNOWN),
            str(lib.get("architecture") or UNKNOWN))


@functools.cache
def _attributes() -> tuple[tuple[str, str], ...]:
    config = np.show_config(mode="dicts")
    blas, blas_version, kernel = _numpy_blas(config.get("Build Dependencies", {}).get("blas", {}))
    simd = config.get("SIMD Extensions", {})
    return (
        ("cpu_architecture", platform.machine() or UNKNOWN),
        ("cpu_model", _cpu_model()),
        ("operating_system", _operating_system()),
        ("python_implementation", platform.python_implementation()),
        ("python_version", platform.python_version()),
        ("numpy_blas", blas),
        ("numpy_blas_version", blas_version),
        ("numpy_blas_kernel", kernel),
        ("numpy_simd", " ".join([*simd.get("baseline", []), *simd.get("found", [])]) or "none"),
    )


def platform_attributes() -> dict[str, str]:
    """The platform this process computes on, as trial root attributes (found once per process).

    Returns
    -------
    dict of str to str
        ``cpu_architecture`` (``x86_64``, ``arm64``), ``cpu_model``, ``operating_system``
        (``Linux glibc 2.36``), ``python_implementation``, ``python_version``, ``numpy_blas``
        (``OpenBLAS``), ``numpy_blas_version``, ``numpy_blas_kernel`` (the kernel the BLAS
        picked for this CPU at run time: ``SkylakeX``, ``Haswell``; ``unknown`` where the
        library does not say), ``numpy_simd`` (NumPy's SIMD extensions in use: its baseline
        and the dispatched ones this CPU has).
    """
    return dict(_attributes())


def platform_summary(attrs: Mapping[str, Any]) -> str:
    """One line naming a trial's platform, from its root attributes (stored or about to be).

    ``x86_64 / OpenBLAS 0.3.31 SkylakeX / numpy 2.4.6 / pinocchio 4.1.0 / CPython 3.11.7``:
    what decides the arithmetic of a trial, for grouping trials by the platform that
    computed them. A stored ``computing_platform`` is returned as it is;
    :data:`NOT_RECORDED` when the attributes hold neither it nor the parts.
    """
    if "computing_platform" in attrs:
        return str(attrs["computing_platform"])
    if "numpy_blas_kernel" not in attrs:
        return NOT_RECORDED

    def get(key: str) -> str:
        return str(attrs.get(key, UNKNOWN))

    return (f"{get('cpu_architecture')} / {get('numpy_blas')} {get('numpy_blas_version')} "
            f"{get('numpy_blas_kernel')} / numpy {get('numpy_version')} / pinocchio {get('pinocchio_version')} "
            f"/ {get('python_implementation')} {get('python_version')}")
