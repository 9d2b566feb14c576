"""The CPUs a process may use, and the maps over a time grid that use them."""

import casadi as ca
import numpy as np
import pytest

from alcove.science import parallel
from alcove.science.parallel import (
    CPUS_PER_PROCESS_ENV,
    affinity_cpus,
    grid_map,
    grid_threads,
    usable_cpus,
)


def test_without_a_cap_a_process_uses_its_affinity(monkeypatch):
    monkeypatch.delenv(CPUS_PER_PROCESS_ENV, raising=False)
    assert usable_cpus() == affinity_cpus() >= 1


def test_the_cap_lowers_the_cpus_and_never_raises_them(monkeypatch):
    monkeypatch.setattr(parallel, "affinity_cpus", lambda: 4)
    monkeypatch.setenv(CPUS_PER_PROCESS_ENV, "1")
    assert usable_cpus() == 1 and grid_threads() == 1
    monkeypatch.setenv(CPUS_PER_PROCESS_ENV, " 3 ")
    assert usable_cpus() == 3
    monkeypatch.setenv(CPUS_PER_PROCESS_ENV, "16")
    assert usable_cpus() == 4
    monkeypatch.setenv(CPUS_PER_PROCESS_ENV, "")
    assert usable_cpus() == 4


@pytest.mark.parametrize("value", ["0", "-2", "two", "1.5"])
def test_a_bad_cap_is_an_error_naming_the_variable(monkeypatch, value):
    monkeypatch.setenv(CPUS_PER_PROCESS_ENV, value)
    with pytest.raises(ValueError, match=f"{CPUS_PER_PROCESS_ENV}: must be a whole number >= 1, got '{value}'"):
        usable_cpus()


def test_grid_map_threads(monkeypatch):
    x = ca.SX.sym("x", 2)
    fn = ca.Function("f", [x], [ca.vertcat(ca.sin(x[0]) * x[1], ca.exp(x[1]))])
    X = np.random.default_rng(0).normal(size=(2, 50))
    serial = np.asarray(grid_map(fn, 50, 1)(X))
    assert grid_map(fn, 50, 1).class_name() == "Map"
    for threads in (2, 3, 64):
        mapped = grid_map(fn, 50, threads)
        # 50 intervals on 3 threads: CasADi maps 48 on the threads and the remaining 2 serially
        kinds = {mapped.class_name()} | {f.class_name() for f in mapped.find_functions()}
        assert "ThreadMap" in kinds
        assert np.array_equal(np.asarray(mapped(X)), serial)
    monkeypatch.setenv(CPUS_PER_PROCESS_ENV, "1")
    assert grid_map(fn, 50).class_name() == "Map"  # the default follows the process's CPUs
    with pytest.raises(ValueError, match="threads: must be >= 1"):
        grid_map(fn, 50, 0)
