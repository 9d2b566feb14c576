"""The report of ``python -m bench.strategies``: the table (mean and spread over seeds per
strategy and oracle budget), the issue's goal checks and the plot, from the per-run result
files or from the results JSON."""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path
from typing import Any

#: strategy names as the goal checks use them
ED, RANDOM, PAPER = "ensemble-disagreement", "random-scenarios", "paper"


def write_atomic(path: Path, data: Any) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def calls_to_reach(curve: list[tuple[int, float]], target: float) -> int | None:
    """The fewest oracle calls at which ``curve`` ((calls, error), ascending calls) is at most ``target``."""
    for calls, err in sorted(curve):
        if err <= target:
            return calls
    return None


# ----------------------------------------------------------------------------- report


def _runs_from(work: Path) -> list[dict[str, Any]]:
    return [json.loads(p.read_text()) for p in sorted(work.glob("run-*.json"))]


def collect(work: Path, meta: dict[str, Any]) -> dict[str, Any]:
    runs = _runs_from(work)
    return {**meta, "runs": runs}


#: what ``merge`` appends to the strategy name of an earlier run that a new run replaces
EARLIER = " (earlier)"


def merge(results: dict[str, Any], earlier: dict[str, Any]) -> dict[str, Any]:
    """``results`` with the runs of an earlier results JSON added: a (strategy, seed) the new
    runs lack is taken as it was (the same strategy, e.g. a re-run of one strategy beside the
    others' earlier runs); one they have is kept for comparison under the strategy's name with
    ``EARLIER`` appended. Budgets, batch and candidates must agree."""
    for key in ("oracle", "task", "budgets", "batch", "candidates", "preliminary_seed", "validation_seed"):
        if results.get(key) != earlier.get(key):
            raise ValueError(f"--merge: {key} differs ({results.get(key)!r} here, {earlier.get(key)!r} there)")
    have = {(r["strategy"], r["seed"]) for r in results["runs"]}
    runs, strategies = list(results["runs"]), list(results["strategies"])
    for r in earlier["runs"]:
        name = r["strategy"] + EARLIER if (r["strategy"], r["seed"]) in have else r["strategy"]
        runs.append({**r, "strategy": name})
        if name not in strategies:
            strategies.append(name)
    order = [PAPER, RANDOM, ED]
    strategies.sort(key=lambda n: (order.index(n.removesuffix(EARLIER)) if n.removesuffix(EARLIER) in order else 9, n))
    return {**results, "runs": runs, "strategies": strategies, "merged_from": earlier.get("started")}


def summary(results: dict[str, Any]) -> dict[str, Any]:
    """Mean, standard deviation, min and max over seeds per (strategy, budget); the goal checks."""
    budgets = [0, *results["budgets"]]
    table: dict[str, dict[int, dict[str, Any]]] = {}
    curves: dict[str, list[list[tuple[int, float]]]] = {}
    for strat in results["strategies"]:
        runs = [r for r in results["runs"] if r["strategy"] == strat]
        table[strat] = {}
        for b in budgets:
            vals = [r["budgets"][str(b)] for r in runs if str(b) in r["budgets"]]
            if not vals:
                continue
            f = [v["force_rmse"] for v in vals]
            m = [v["moment_rmse"] for v in vals]
            table[strat][b] = {
                "n": len(vals),
                "seeds": [r["seed"] for r in runs if str(b) in r["budgets"]],
                "force_mean": statistics.fmean(f),
                "force_sd": statistics.stdev(f) if len(f) > 1 else 0.0,
                "force_min": min(f),
                "force_max": max(f),
                "moment_mean": statistics.fmean(m),
                "moment_sd": statistics.stdev(m) if len(m) > 1 else 0.0,
            }
        # the validation error of every model version over the oracle calls its pool holds
        per_seed = []
        for r in runs:
            cum, total, cv = {}, 0, []
            for it in r.get("iterations", []):
                total += it["oracle_calls"]
                cum[it["k"]] = total
            for it in r.get("iterations", []):
                v = it.get("validation_of_model_k")
                if v is not None and it["k"] - 1 in cum:
                    cv.append((cum[it["k"] - 1], v[0]))
            # the scored budgets (their model may be the last one trained, never evaluated in the loop)
            seen = {c for c, _ in cv}
            cv += [(v["oracle_calls"], v["force_rmse"]) for v in r["budgets"].values() if v["oracle_calls"] not in seen]
            if cv:
                per_seed.append(sorted(cv))
        curves[strat] = per_seed
    goals: dict[str, Any] = {}
    ed, rnd, pap = (table.get(s, {}) for s in (ED, RANDOM, PAPER))
    top = max(results["budgets"])
    common = [b for b in results["budgets"] if b in ed and b in rnd]
    if common:
        goals["beats_random"] = {
            str(b): {
                "ed": ed[b]["force_mean"],
                "random": rnd[b]["force_mean"],
                "ratio": ed[b]["force_mean"] / rnd[b]["force_mean"],
            }
            for b in common
        }
        goals["beats_random_every_budget"] = all(ed[b]["force_mean"] < rnd[b]["force_mean"] for b in common)
    # the budgets' means (each seed's model after at most B calls): a batch strategy's seeds reach
    # different call counts (ensemble-disagreement picks fewer than q when few candidates touch), so
    # the budgets, not the seeds' common call counts, are where their mean is defined
    seeds_ed = max((r["n"] for r in ed.values()), default=0)
    ed_curve = [(b, ed[b]["force_mean"]) for b in sorted(ed) if b > 0 and ed[b]["n"] == seeds_ed]
    for name, ref, limit in (("random", rnd, top // 2), ("paper", pap, top // 4)):
        if top in ref and ed_curve:
            target = ref[top]["force_mean"]
            need = calls_to_reach(ed_curve, target)
            goals[f"reach_{name}_{top}"] = {
                "target_force_rmse": target,
                "calls_needed": need,
                "limit": limit,
                "met": need is not None and need <= limit,
                "ed_at_limit": dict(ed_curve).get(limit),
                "ed_calls_measured": max(c for c, _ in ed_curve),  # the largest budget on every seed
            }
    return {"table": table, "curves": curves, "goals": goals, "picks": picks(results)}


RANGES = {"initial.q.0": (0.15, 0.30), "initial.qd.0": (0.0, 0.5), "model.headrest_offset": (-0.005, 0.005)}


def picks(results: dict[str, Any]) -> dict[str, Any]:
    """Where the replayed scenarios land (mean of each ranged parameter scaled to [0, 1] over its
    range; uniform draws give 0.5), their in-loop force RMSE, and for ensemble-disagreement the
    scores of picked and unpicked candidates and how the score ranks the picks' actual error."""
    from scipy.stats import spearmanr

    out: dict[str, Any] = {}
    for strat in results["strategies"]:
        chosen, others, err, score_err = [], [], [], []
        for r in (r for r in results["runs"] if r["strategy"] == strat):
            for it in r.get("iterations", []):
                for c in it["candidates"]:
                    (chosen if c["pick"] is not None else others).append(c)
                    if c["pick"] is not None and c["force_rmse"] is not None:
                        err.append(c["force_rmse"])
                        if c["score"] is not None:
                            score_err.append((c["score"], c["force_rmse"]))
        if not chosen:
            continue
        row: dict[str, Any] = {
            "replayed": len(chosen),
            "in_loop_force_rmse_mean": statistics.fmean(err) if err else None,
            "scaled_mean": {
                k: statistics.fmean((c["values"][k] - lo) / (hi - lo) for c in chosen if c["values"])
                for k, (lo, hi) in RANGES.items()
            },
        }
        scored = [c["score"] for c in chosen if c["score"] is not None]
        if scored:
            rest = [c["score"] for c in others if c["score"] is not None]
            row["score_picked_mean"] = statistics.fmean(scored)
            row["score_unpicked_mean"] = statistics.fmean(rest) if rest else None
            row["not_converged"] = sum(1 for c in chosen + others if c["converged"] is False)
            row["candidates"] = len(chosen) + len(others)
        if len(score_err) > 2:
            rho = spearmanr([s for s, _ in score_err], [e for _, e in score_err])
            row["spearman_score_vs_in_loop_error"] = float(rho.statistic)
        out[strat] = row
    return out


def print_table(results: dict[str, Any], summ: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console() if sys.stdout.isatty() else Console(width=160)
    t = Table(title=f"validation-suite error at equal oracle budgets ({results['oracle']}, {results['task']})")
    for c in (
        "strategy",
        "oracle calls",
        "seeds",
        "force RMSE [N] mean +- sd",
        "min - max",
        "moment RMSE [N m] mean +- sd",
    ):
        t.add_column(c, justify="left" if c == "strategy" else "right")
    for strat, rows in summ["table"].items():
        for b, r in sorted(rows.items()):
            t.add_row(
                strat,
                str(b),
                str(r["n"]),
                f"{r['force_mean']:.2f} +- {r['force_sd']:.2f}",
                f"{r['force_min']:.2f} - {r['force_max']:.2f}",
                f"{r['moment_mean']:.3f} +- {r['moment_sd']:.3f}",
            )
    console.print(t)
    console.print(json.dumps({"goals": summ["goals"], "picks": summ["picks"]}, indent=1))


def plot(results: dict[str, Any], summ: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    colors = {"paper": "tab:gray", "random-scenarios": "tab:blue", "ensemble-disagreement": "tab:red"}
    for ax, key, unit in ((axes[0], "force", "N"), (axes[1], "moment", "N m")):
        for strat, rows in summ["table"].items():
            bs = sorted(b for b in rows if b > 0)
            if not bs:
                continue
            mean = [rows[b][f"{key}_mean"] for b in bs]
            sd = [rows[b][f"{key}_sd"] for b in bs]
            ax.errorbar(
                bs,
                mean,
                yerr=sd,
                marker="o",
                capsize=3,
                color=colors.get(strat.removesuffix(EARLIER)),
                ls="--" if strat.endswith(EARLIER) else "-",
                alpha=0.55 if strat.endswith(EARLIER) else 1.0,
                label=f"{strat} (n={rows[bs[0]]['n']})",
            )
            if 0 in rows:
                ax.axhline(rows[0][f"{key}_mean"], color="k", lw=0.6, ls=":")
        if key == "force":
            for strat, per_seed in summ["curves"].items():
                if strat.endswith(EARLIER):
                    continue
                for cv in per_seed:
                    xs = [c for c, _ in cv if c > 0]
                    ys = [e for c, e in cv if c > 0]
                    ax.plot(xs, ys, color=colors.get(strat), lw=0.6, alpha=0.35)
        ax.set_xscale("log", base=2)
        ax.set_xticks(results["budgets"], [str(b) for b in results["budgets"]])
        ax.set_xlabel("oracle calls (pool the model was trained on)")
        ax.set_ylabel(f"validation-suite {key} RMSE [{unit}]")
        ax.grid(alpha=0.3)
    axes[0].set_title("force (mean +- sd over seeds; thin: every model version)", fontsize=9)
    axes[1].set_title("moment (mean +- sd over seeds); dotted: preliminary-only model", fontsize=9)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def report(results: dict[str, Any], out: Path, plot_path: Path) -> dict[str, Any]:
    summ = summary(results)
    results["summary"] = {
        "table": {s: {str(b): r for b, r in rows.items()} for s, rows in summ["table"].items()},
        "goals": summ["goals"],
        "picks": summ["picks"],
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(out, results)
    plot(results, summ, plot_path)
    print_table(results, summ)
    print(f"wrote {out} and {plot_path}")
    return summ
