"""The CPUs science code may use, and CasADi maps over a time grid that use them.

A DMOCC NLP evaluates the same small function on every interval of its grid (the discrete
Euler-Lagrange residuals with the contact model, their local Jacobian and Hessian blocks). The
intervals are independent, so CasADi's ``Function.map(n, "thread", threads)`` evaluates them on
several threads at once, each thread with its own work memory. The values are the serial map's,
bit for bit: each interval is computed by the same instructions, only on another thread.
"""

from __future__ import annotations

import os

import casadi as ca

#: a cap: a 200-interval grid split over more threads leaves each too little work to pay its start
MAX_GRID_THREADS = 8


def usable_cpus() -> int:
    """The CPUs this process may run on (its affinity where the OS reports one, else the machine's)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def grid_threads() -> int:
    """Threads for a map over a time grid: the usable CPUs, at most :data:`MAX_GRID_THREADS`."""
    return max(1, min(usable_cpus(), MAX_GRID_THREADS))


def grid_map(fn: ca.Function, n: int, threads: int | None = None) -> ca.Function:
    """``fn`` mapped over ``n`` columns, on ``threads`` threads (default :func:`grid_threads`;
    1: CasADi's serial map)."""
    threads = grid_threads() if threads is None else threads
    if threads < 1:
        raise ValueError(f"threads: must be >= 1, got {threads}")
    threads = min(threads, n)
    if threads == 1:
        return fn.map(n)
    return fn.map(n, "thread", threads)


__all__ = ["MAX_GRID_THREADS", "grid_map", "grid_threads", "usable_cpus"]
