"""``python -m transgen.sim.core.build_kernels [--quiet]``: build the simulator's kernels ahead of time
now (:mod:`.aot`), e.g. once after an install or in a container's image; exit 1 where they cannot
be built (numba, a C compiler or a writable folder missing). A first simulation without them
starts this in the background itself."""
from __future__ import annotations

import sys
import time

from . import aot
from .jit import numba_clone

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    quiet = "--quiet" in (argv if argv is not None else sys.argv[1:])
    start = time.perf_counter()
    module = aot.build(numba_clone, wait=True)
    if not quiet:
        where = module.__file__ if module is not None else "not built (numba, a C compiler or a writable folder missing)"
        print(f"transgen kernels: {where} ({time.perf_counter() - start:.1f} s)")
    return 0 if module is not None else 1


if __name__ == "__main__":
    sys.exit(main())
