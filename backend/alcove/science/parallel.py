"""The CPUs science code may use, and CasADi maps over a time grid that use them.

A process may use the CPUs it may run on (its affinity), or fewer when ``ALCOVE_CPUS_PER_PROCESS``
says so (set by the user; a worker does not share its CPUs out by itself: docs/ocp.md).

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


#: the environment variable that caps the CPUs one process uses (a whole number >= 1)
CPUS_PER_PROCESS_ENV = "ALCOVE_CPUS_PER_PROCESS"


def affinity_cpus() -> int:
    """The CPUs this process may run on (its affinity where the OS reports one, else the machine's)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def usable_cpus() -> int:
    """The CPUs this process may use: :func:`affinity_cpus`, at most ``ALCOVE_CPUS_PER_PROCESS``
    when that is set. A value that is not a whole number >= 1 raises ``ValueError`` naming it."""
    cpus = affinity_cpus()
    raw = os.environ.get(CPUS_PER_PROCESS_ENV, "").strip()
    if not raw:
        return cpus
    try:
        cap = int(raw)
    except ValueError:
        cap = 0
    if cap < 1:
        raise ValueError(f"{CPUS_PER_PROCESS_ENV}: must be a whole number >= 1, got {raw!r}")
    return min(cpus, cap)


def grid_threads() -> int:
    """Threads for a map over a time grid: the usable CPUs, at most :data:`MAX_GRID_THREADS`."""
    return min(usable_cpus(), MAX_GRID_THREADS)


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


__all__ = [
    "CPUS_PER_PROCESS_ENV",
    "MAX_GRID_THREADS",
    "affinity_cpus",
    "grid_map",
    "grid_threads",
    "usable_cpus",
]
