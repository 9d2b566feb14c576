"""The reproduction's figures (PNG files next to the page), drawn with matplotlib.

matplotlib is not a dependency of alcove itself but of its ``reproduce`` extra:
:func:`matplotlib_missing` says how to install it, before a run starts.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .record import RELEVANT

INSTALL_HINT = "pip install -e '.[reproduce]' (make reproduce installs it)"


def matplotlib_missing() -> str | None:
    """None if matplotlib can be imported, else what to do about it."""
    try:
        import matplotlib  # noqa: F401
    except ImportError as err:
        return f"the reproduction draws its figures with matplotlib, which is not installed ({err}): {INSTALL_HINT}"
    return None


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"figure.dpi": 110, "axes.grid": True, "grid.alpha": 0.3, "font.size": 9})
    return plt


def _shade_phases(ax: Any, phases: list[tuple[str, float, float]]) -> None:
    for i, (name, a, b) in enumerate(phases):
        ax.axvspan(a, b, color=("#dbe9f6" if i % 2 == 0 else "#f6e8db"), alpha=0.6, lw=0)
        ax.text(0.5 * (a + b), 1.0, name, transform=ax.get_xaxis_transform(), ha="center", va="bottom", fontsize=8)


def multibody(path: Path, sol: Any, dq: Any, u: Any, phases: list[tuple[str, float, float]]) -> None:
    """Joint angle relative to the start and joint torque over time, phases shaded."""
    plt = _plt()
    fig, axes = plt.subplots(2, 1, figsize=(6.4, 4.6), sharex=True)
    for ax in axes:
        _shade_phases(ax, phases)
    axes[0].plot(sol.t, dq, "k-")
    axes[0].set_ylabel(r"$\theta - \theta_0$ [rad]")
    axes[1].step(sol.t[:-1], u, where="post", color="C3")
    axes[1].set_ylabel(r"joint torque $\tau$ [N m]")
    axes[1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def fe_replay(path: Path, results: list[tuple[str, Any, float]]) -> None:
    """The relevant force and moment components of each FE replay, one column per motion."""
    import numpy as np

    plt = _plt()
    fig, axes = plt.subplots(len(RELEVANT), len(results), figsize=(4.2 * len(results), 5.6), sharex=True, squeeze=False)
    for c, (label, res, _) in enumerate(results):
        fs = res.forces
        w = np.concatenate([fs.force, fs.moment], axis=1)
        fc = res.diagnostics.get("first_contact_time_s")
        for r, (name, j, unit) in enumerate(RELEVANT):
            ax = axes[r, c]
            ax.plot(fs.t, w[:, j], "k-")
            if fc is not None:
                ax.axvline(fc, color="C3", ls=":", lw=1)
            ax.set_ylabel(f"{name} [{unit}]")
        axes[0, c].set_title(f"{label}" + (f"\nfirst contact {fc:.4g} s" if fc is not None else ""), fontsize=9)
        axes[-1, c].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def campaign_rmse(path: Path, k: Any, f: Any, m: Any, f_median: Any, m_median: Any, window: int) -> None:
    """Force and moment RMSE per iteration on a log axis, with their rolling medians."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    ax.semilogy(k, f, ".-", color="C0", alpha=0.35, lw=0.6, label="force RMSE [N]")
    ax.semilogy(k, m, ".-", color="C1", alpha=0.35, lw=0.6, label="moment RMSE [N m]")
    ax.semilogy(k, f_median, "-", color="C0", label=f"force, rolling median ({window})")
    ax.semilogy(k, m_median, "-", color="C1", label=f"moment, rolling median ({window})")
    ax.set_xlabel("iteration k")
    ax.set_ylabel("RMSE on iteration k's trajectory")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def campaign_last(path: Path, curves: Any) -> None:
    """True (oracle) and predicted (surrogate) curves along one iteration's trajectory."""
    import numpy as np

    plt = _plt()
    t = np.asarray(curves.t)
    ft, fp = np.asarray(curves.f_true), np.asarray(curves.f_pred)
    fig, axes = plt.subplots(len(RELEVANT), 1, figsize=(6.4, 5.6), sharex=True)
    for ax, (name, j, unit) in zip(axes, RELEVANT, strict=False):
        ax.plot(t, ft[:, j], "k-", label="true (oracle)")
        ax.plot(t, fp[:, j], "--", color="C2", label="predicted (surrogate)")
        ax.set_ylabel(f"{name} [{unit}]")
    axes[0].legend(fontsize=7)
    axes[0].set_title(f"iteration {curves.iteration_index}", fontsize=9)
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def remedies(path: Path, series: list[tuple[str, Any, Any, Any]]) -> None:
    """Force and moment RMSE per iteration of each campaign (label, k, force, moment)."""
    plt = _plt()
    from matplotlib.ticker import MaxNLocator

    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.4))
    for i, (label, k, f, m) in enumerate(series):
        axes[0].semilogy(k, f, "o-", ms=3, color=f"C{i}", label=label)
        axes[1].semilogy(k, m, "o-", ms=3, color=f"C{i}", label=label)
    axes[0].set_ylabel("force RMSE [N]")
    axes[1].set_ylabel("moment RMSE [N m]")
    for ax in axes:
        ax.set_xlabel("iteration of the campaign")
    axes[0].legend(fontsize=6)
    for ax in axes:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
