"""Pools built from known smooth functions of (q, qd) for the surrogate tests."""

from __future__ import annotations

import numpy as np
import pytest

from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.dataset import PoolDataset


def smooth_wrench(q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A smooth 'contact law' in the planar components; fy, mx, mz vanish (zero variance)."""
    z = np.zeros_like(q)
    force = np.stack([40 * np.sin(4 * q) + 8 * q * qd, z, 5 * np.cos(3 * q) - qd], -1)
    moment = np.stack([z, 2 * q - 0.5 * qd**2, z], -1)
    return force, moment


def make_smooth_pool(
    n_sims: int = 20, n_samples: int = 100, seed: int = 0, origin: str = "oracle", prefix: str = "sim"
) -> list[PoolDataset]:
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n_samples)
    pool = []
    for i in range(n_sims):
        a, c, f, ph = rng.uniform(0.05, 0.2), rng.uniform(0.1, 0.35), rng.uniform(0.5, 1.5), rng.uniform(0, 2 * np.pi)
        q = c + a * np.sin(2 * np.pi * f * t + ph)
        qd = 2 * np.pi * f * a * np.cos(2 * np.pi * f * t + ph)
        force, moment = smooth_wrench(q, qd)
        pool.append(PoolDataset(f"{prefix}-{i:03d}", t, q, qd, force, moment, origin))
    return pool


@pytest.fixture(scope="session")
def smooth_pool() -> list[PoolDataset]:
    return make_smooth_pool()


@pytest.fixture(scope="session")
def trained_smooth(smooth_pool):
    """The paper's protocol trained once on the smooth pool (shared by several tests)."""
    from alcove.science.surrogate.training import train_surrogate

    # float64: the tests that share it compare to float64 tolerances (export parity, round trips);
    # patience in epochs alone (the paper's rule): this noise-free law improves for 1000 epochs otherwise
    config = SurrogateConfig(ensemble_size=1, dtype="float64", patience_steps=0)
    return train_surrogate(smooth_pool, config, seed=0)


def contact_wrench(q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A contact law of the geometry: zero where the signed gap is open, a normal force growing with
    the penetration (and the velocity) where it is closed, friction-like fz and a moment my."""
    from alcove.science.geometry import DEFAULT_PRESET, signed_gap

    pen = np.maximum(-signed_gap(DEFAULT_PRESET, q), 0.0)
    fx = 1e6 * pen**2 * (1.0 + 0.1 * qd)
    z = np.zeros_like(q)
    return np.stack([fx, z, 0.3 * fx], -1), np.stack([z, -0.06 * fx, z], -1)


def make_contact_pool(n_sims: int = 16, n_samples: int = 100, seed: int = 0) -> list[PoolDataset]:
    """Oscillations about the first-contact angle: every simulation has open and closed phases."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n_samples)
    pool = []
    for i in range(n_sims):
        a, c, f, ph = rng.uniform(0.04, 0.1), rng.uniform(0.27, 0.35), rng.uniform(0.5, 1.5), rng.uniform(0, 2 * np.pi)
        q = c + a * np.sin(2 * np.pi * f * t + ph)
        qd = 2 * np.pi * f * a * np.cos(2 * np.pi * f * t + ph)
        force, moment = contact_wrench(q, qd)
        pool.append(PoolDataset(f"contact-{i:03d}", t, q, qd, force, moment, "oracle"))
    return pool


@pytest.fixture(scope="session")
def contact_pool() -> list[PoolDataset]:
    return make_contact_pool()
