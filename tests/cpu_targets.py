"""Other CPUs on this one: the switches that make numpy, OpenBLAS and glibc's libm run the kernels an older CPU
would, so that a result that depends on the CPU shows as a difference on any one machine (issue 27).

- numpy: NPY_DISABLE_CPU_FEATURES names the SIMD targets its ufuncs dispatch to beyond its baseline (those this CPU
  has: numpy refuses a name it does not know here);
- OpenBLAS: OPENBLAS_CORETYPE picks the kernel of a named CPU (its DYNAMIC_ARCH build, as numpy's wheels ship): only
  older ones than any x86-64 machine we run on, which fuse no multiply-add (Sandybridge: AVX; Prescott: SSE3);
- glibc: GLIBC_TUNABLES=glibc.cpu.hwcaps=-FMA,... masks features from its IFUNC selection, so libm's sin, cos, exp,
  log, pow, atan2, ... take their non-FMA variants (the names of glibc >= 2.26; -AVX2_Usable, older, does nothing on
  2.36, checked by test_bit_identical's probe).
"""

from __future__ import annotations

from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__


def _numpy_dispatch_off() -> dict[str, str]:
    """numpy's dispatched SIMD targets this CPU runs, all switched off (empty if it runs only its baseline)."""
    used = [name for name in __cpu_dispatch__ if __cpu_features__.get(name)]
    return {"NPY_DISABLE_CPU_FEATURES": " ".join(used)} if used else {}


def targets() -> dict[str, dict[str, str]]:
    """name -> the environment that makes this machine compute as that (older) CPU would."""
    numpy_off = _numpy_dispatch_off()
    return {
        "sandybridge": {
            "OPENBLAS_CORETYPE": "Sandybridge", "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4", **numpy_off,
        },
        "prescott": {
            "OPENBLAS_CORETYPE": "Prescott", "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX,-AVX2,-FMA,-FMA4", **numpy_off,
        },
    }  # fmt: skip


# What the probe computes with the CPU-dependent kernels themselves: libm through Python's math, BLAS through @.
PROBE = """
import hashlib, math, random
import numpy as np
r = random.Random(1)
xs = [r.uniform(-50.0, 50.0) for _ in range(100000)]
libm = [math.sin(x) for x in xs] + [math.exp(x / 10.0) for x in xs] + [math.atan2(x, 1.3) for x in xs]
a = np.random.default_rng(0).standard_normal((64, 64))
print(hashlib.sha256(repr(libm).encode()).hexdigest(), hashlib.sha256((a @ a).tobytes()).hexdigest())
"""
