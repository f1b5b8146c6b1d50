"""Is a reader linear in its input's size? Time it on an input and on one ten times the size.

A ratio of CPU times within one test, not a timing: the best of a few runs of each size,
interleaved (the machine is shared), must grow less than ``limit`` times for ten times the input.
Linear gives about 10, quadratic about 100, so the margin takes the noise of a busy machine.
"""

from __future__ import annotations

import time


def cpu_seconds(run, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        run()
        best = min(best, time.process_time() - t0)
    return best


def growth(make, run, n: int, repeat: int = 3) -> float:
    """CPU time of ``run(make(10 n))`` over that of ``run(make(n))``, each the best of ``repeat``,
    the sizes interleaved."""
    small, large = make(n), make(10 * n)
    run(small)  # warm: imports, caches
    ts, tl = float("inf"), float("inf")
    for _ in range(repeat):
        ts = min(ts, cpu_seconds(lambda: run(small), 1))
        tl = min(tl, cpu_seconds(lambda: run(large), 1))
    return tl / max(ts, 1e-4)


def assert_linear(make, run, n: int, limit: float = 30.0, repeat: int = 3) -> None:
    g = growth(make, run, n, repeat)
    assert g < limit, f"ten times the input took {g:.0f} times as long (linear: about 10)"
