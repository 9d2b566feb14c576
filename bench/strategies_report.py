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
ED, RANDOM, PAPER, FAMILY, BEST = (
    "ensemble-disagreement",
    "random-scenarios",
    "paper",
    "press-family",
    "best-possible",
)
#: the quantities of a budget's row summarised over seeds (median, min, max)
QUANTITIES = ("force", "moment", "fx", "fz", "my", "calibration")


def _key(q: str) -> str:
    return "calibration" if q == "calibration" else f"{q}_rmse"


def spread(vals: list[dict[str, Any]]) -> dict[str, Any]:
    """Median, min and max over seeds of each quantity (those the rows have)."""
    out: dict[str, Any] = {}
    for q in QUANTITIES:
        xs = [v[_key(q)] for v in vals if v.get(_key(q)) is not None]
        if xs:
            out[q] = {"median": statistics.median(xs), "min": min(xs), "max": max(xs)}
    return out


def targets(table: dict[str, dict[int, dict[str, Any]]]) -> dict[str, Any]:
    """The issue's targets against the best-possible line (medians over seeds): every strategy's fx
    within 1.3x of the line's at 32 calls and 1.5x at 16; the best strategy's force within 1.2x at
    32; a strategy reaching the line's 32-call force error in at most 16 calls; every strategy's
    calibration >= 0.8 at 32. Each with the measured ratios."""
    strategies = [s for s in table if s != BEST and not s.endswith(EARLIER)]
    out: dict[str, Any] = {}

    def median(s: str, b: int, q: str) -> float | None:
        row = table.get(s, {}).get(b, {}).get("spread", {}).get(q)
        return None if row is None else row["median"]

    for b, limit in ((32, 1.3), (16, 1.5)):
        ref = median(BEST, b, "fx")
        ratios = {s: (v / ref if (v := median(s, b, "fx")) is not None and ref else None) for s in strategies}
        met = all(r is not None and r <= limit for r in ratios.values()) if ratios else None
        out[f"fx_within_{limit}x_at_{b}"] = {"reference": ref, "ratios": ratios, "met": met}
    ref32 = median(BEST, 32, "force")
    ratios = {s: (v / ref32 if (v := median(s, 32, "force")) is not None and ref32 else None) for s in strategies}
    best_ratio = min((r for r in ratios.values() if r is not None), default=None)
    out["best_force_within_1.2x_at_32"] = {
        "reference": ref32,
        "ratios": ratios,
        "met": None if best_ratio is None else best_ratio <= 1.2,
    }
    reach = {}
    for s in strategies:
        curve = [(b, v) for b in sorted(table[s]) if b > 0 and (v := median(s, b, "force")) is not None]
        reach[s] = calls_to_reach(curve, ref32) if ref32 is not None else None
    out["reach_reference_32_in_16"] = {
        "target": ref32,
        "calls_needed": reach,
        "met": any(c is not None and c <= 16 for c in reach.values()) if reach else None,
    }
    cal = {s: median(s, 32, "calibration") for s in strategies}
    out["calibration_0.8_at_32"] = {
        "medians": cal,
        "reference": median(BEST, 32, "calibration"),
        "met": all(c is not None and c >= 0.8 for c in cal.values()) if cal else None,
    }
    return out


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
    order = [BEST, PAPER, RANDOM, ED, FAMILY]
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
                "spread": spread(vals),
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
    goals["targets"] = targets(table)
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
            # where the replayed scenarios land (none drawn: press-family replays motions of the nominal task)
            "scaled_mean": {
                k: statistics.fmean((c["values"][k] - lo) / (hi - lo) for c in chosen if c["values"])
                for k, (lo, hi) in RANGES.items()
                if any(c["values"] for c in chosen)
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


COLUMNS = (
    "strategy",
    "oracle calls",
    "seeds",
    "force [N]",
    "fx [N]",
    "fz [N]",
    "my [N m]",
    "calibration",
    "force / best",
    "fx / best",
)


def table_rows(summ: dict[str, Any]) -> list[list[str]]:
    """Per strategy and budget, the cells of :data:`COLUMNS`: the median over seeds (min - max) of
    the suite's force, fx, fz, my RMSE and calibration, and the force and fx medians over the
    best-possible line's."""
    out = []
    best = summ["table"].get(BEST, {})
    for strat, rows in summ["table"].items():
        for b, r in sorted(rows.items()):
            sp = r["spread"]
            cells = [
                f"{sp[q]['median']:.2f} ({sp[q]['min']:.2f}-{sp[q]['max']:.2f})" if q in sp else ""
                for q in ("force", "fx", "fz", "my", "calibration")
            ]
            ratios = []
            for q in ("force", "fx"):
                ref = best.get(b, {}).get("spread", {}).get(q)
                ratios.append(f"{sp[q]['median'] / ref['median']:.2f}" if ref and q in sp else "")
            out.append([strat, str(b), str(r["n"]), *cells, *ratios])
    return out


def print_table(results: dict[str, Any], summ: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console() if sys.stdout.isatty() else Console(width=200)
    t = Table(title=f"validation-suite error at equal oracle budgets ({results['oracle']}, {results['task']})")
    for c in COLUMNS:
        t.add_column(c, justify="left" if c == "strategy" else "right")
    for row in table_rows(summ):
        t.add_row(*row)
    console.print(t)
    console.print(json.dumps({"goals": summ["goals"], "picks": summ["picks"]}, indent=1))


def markdown(summ: dict[str, Any]) -> str:
    """The table of :func:`print_table` in Markdown (for docs/active-learning.md)."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "| " + " | ".join(["---"] * len(COLUMNS)) + " |"]
    lines += ["| " + " | ".join(row) + " |" for row in table_rows(summ)]
    return "\n".join(lines) + "\n"


def plot(results: dict[str, Any], summ: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(18, 4.2))
    colors = {
        PAPER: "tab:gray",
        RANDOM: "tab:blue",
        ED: "tab:red",
        FAMILY: "tab:green",
        BEST: "k",
    }
    panels = (("force", "force RMSE [N]"), ("fx", "fx RMSE [N]"), ("fz", "fz RMSE [N]"), ("calibration", "calibration"))
    for ax, (key, label) in zip(axes, panels, strict=True):
        for strat, rows in summ["table"].items():
            bs = sorted(b for b in rows if b > 0 and key in rows[b]["spread"])
            if not bs:
                continue
            med = [rows[b]["spread"][key]["median"] for b in bs]
            lo = [m - rows[b]["spread"][key]["min"] for b, m in zip(bs, med, strict=True)]
            hi = [rows[b]["spread"][key]["max"] - m for b, m in zip(bs, med, strict=True)]
            ax.errorbar(
                bs,
                med,
                yerr=[lo, hi],
                marker="D" if strat == BEST else "o",
                capsize=3,
                color=colors.get(strat.removesuffix(EARLIER)),
                ls="--" if strat.endswith(EARLIER) or strat == BEST else "-",
                alpha=0.55 if strat.endswith(EARLIER) else 1.0,
                label=f"{strat} (n={rows[bs[0]]['n']})",
            )
            if 0 in rows and key in rows[0]["spread"]:
                ax.axhline(rows[0]["spread"][key]["median"], color="k", lw=0.6, ls=":")
        if key == "calibration":
            ax.axhline(0.8, color="tab:orange", lw=0.8, ls="-.")
        ax.set_xscale("log", base=2)
        ax.set_xticks(results["budgets"], [str(b) for b in results["budgets"]])
        ax.set_xlabel("oracle calls (pool the model was trained on)")
        ax.set_ylabel(f"validation suite: {label}")
        ax.grid(alpha=0.3)
    axes[0].set_title("median over seeds, bars min-max; dotted: preliminary-only model", fontsize=9)
    axes[3].set_title("share of oracle values inside mean +- 2 std (target 0.8)", fontsize=9)
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
    out.with_suffix(".md").write_text(markdown(summ))
    print_table(results, summ)
    print(f"wrote {out} and {plot_path}")
    return summ
