"""The vector units the compiled kernels run on: the CPU numba compiles for (the host, or ``NUMBA_CPU_NAME``) and
how many float64 values one of its vector registers holds."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import llvmlite.binding as ll
import numba

__all__ = ["VectorUnits", "vector_units"]


@dataclass(frozen=True)
class VectorUnits:
    """``cpu``: LLVM's name of the target CPU (``znver3``, ``skylake-avx512``, ``generic``); ``features``: its
    vector instruction sets (``sse2`` … ``avx512f``, ``fma``); ``doubles``: float64 lanes of one vector register
    (2 with SSE2, 4 with AVX/AVX2, 8 with AVX-512)."""

    cpu: str
    features: tuple[str, ...]
    doubles: int

    def describe(self) -> str:
        """One line for benchmark output: ``znver3 (avx2, fma; 4 float64 per vector)``."""
        shown = [f for f in ("avx512f", "avx2", "avx", "fma", "sse4.2", "sse2") if f in self.features]
        return f"{self.cpu} ({', '.join(shown) or 'no SIMD extension'}; {self.doubles} float64 per vector)"


@lru_cache(maxsize=1)
def vector_units() -> VectorUnits:
    """The target numba compiles the kernels for: ``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES`` where set (the
    generic target has SSE2 only; a named CPU should come with its features, as numba's documentation advises for
    portable caches: without them the host's are assumed), else the host as LLVM detects it.  Asked once per
    process (numba fixes its target when it starts)."""
    name = numba.config.CPU_NAME
    if name and (name == "generic" or numba.config.CPU_FEATURES):
        feats = numba.config.CPU_FEATURES or ""
        on = {f[1:] for f in feats.split(",") if f.startswith("+")}
        if name == "generic":
            on |= {"sse2"}   # x86-64 baseline
    elif name:   # a named CPU without its features: LLVM derives them from the name; take the host's as the best guess
        on = {k for k, v in ll.get_host_cpu_features().items() if v}
    else:
        name = ll.get_host_cpu_name()
        on = {k for k, v in ll.get_host_cpu_features().items() if v}
    vec = tuple(sorted(f for f in on if f.startswith(("sse", "avx")) or f == "fma"))
    doubles = 8 if "avx512f" in on else 4 if ("avx" in on or "avx2" in on) else 2
    return VectorUnits(str(name), vec, doubles)
