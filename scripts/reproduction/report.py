"""The page a run writes (``OUT/reproduction.md``): the machine, the run, the comparison table,
each part's texts and figures, the verdict on each of the paper's claims, and how our model
differs from the paper's."""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import math
import os
import platform
import subprocess
from pathlib import Path
from typing import Any

from .record import REPO, Report, fmt


def machine() -> dict[str, str]:
    import numpy
    import scipy

    info = {"python": platform.python_version(), "platform": platform.platform(), "cpus": str(os.cpu_count())}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                info["cpu"] = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    with contextlib.suppress(OSError):
        info["load average at start"] = " ".join(f"{x:.2f}" for x in os.getloadavg())
    versions = {"numpy": numpy.__version__, "scipy": scipy.__version__}
    for mod in ("casadi", "torch", "skfem"):
        try:
            versions[mod] = __import__(mod).__version__
        except Exception:
            versions[mod] = "not importable"
    info["libraries"] = ", ".join(f"{k} {v}" for k, v in versions.items())
    try:
        info["alcove commit"] = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        info["alcove commit"] = "unknown"
    return info


SECTION_TITLES = {
    "multibody": "1. The multibody solution",
    "fe": "2. FE replay with `fe-headrest-2d`",
    "sweep": "2b. The approach: a sweep of the cost weights w_T / w_tau",
    "campaign": "3. The active-learning loop",
    "remedies": "4. Remedies against the baseline",
}

FIGURES: dict[str, list[tuple[str, str]]] = {
    "sweep": [],
    "multibody": [
        (
            "multibody.png",
            "Joint angle relative to the start and joint torque of the OCP solution with the auxiliary contact; "
            "phases shaded.",
        )
    ],
    "fe": [
        (
            "fe_replay.png",
            "Contact force and moment on the head in the headrest frame H "
            "(fx > 0 pushes the head off the cushion; my about the head COG); dotted: first contact.",
        )
    ],
    "campaign": [
        (
            "campaign_rmse.png",
            "Force and moment RMSE between the surrogate k and the oracle on iteration k's trajectory, "
            "log axis, with a rolling median.",
        ),
        (
            "campaign_last.png",
            "True (oracle) and predicted (surrogate) force and moment along the last iteration's trajectory.",
        ),
    ],
    "remedies": [("remedies.png", "RMSE per iteration of the remedies against the baseline.")],
}

DIFFERENCES = """\
## Where our model differs from the paper's, and what that means

- **FE model.** The paper replays the motion in LS-DYNA with the THUMS v4.1 head (parietal and
  occipital bones and skin) against the 2012 Toyota Camry passenger headrest, a 3D mesh with
  `*MAT_LOW_DENSITY_FOAM`. alcove's `fe-headrest-2d` is a 2D plane-strain cushion block
  (Ogden-Storakers hyperfoam with Kelvin-Voigt viscosity, penalty contact with friction, a
  quasi-static implicit solve per step) against the rigid elliptic occipital profile of the
  shared geometry, turned into newtons by an out-of-plane width (one slice by default, or
  several slices through an ellipsoidal head). Its foam curve is a firm PU headrest foam chosen
  within the range of the literature, not data of the Camry foam. Forces therefore agree with the
  paper in kind (sign, timing, shape) and order of magnitude, not in value. Details:
  [fe-oracle.md](fe-oracle.md#how-this-differs-from-the-papers-ls-dyna-model).
- **Moments.** alcove's moment is taken about the head frame origin (the head COG). With the
  preset's head profile the contact resultant passes a few centimetres from it, which gives a
  few N m per 100 N; the paper's 10-30 N m come from its own head geometry and reference
  point, which it does not state. Compare the moment's shape and sign, not its size.
- **Frames and signs.** alcove reports the contact force on the head in the headrest frame H
  (x_H the outward cushion normal, so fx > 0 pushes the head away; the planar model has only
  fx, fz and my). The paper plots "the relevant coordinates" in its own headrest system; signs
  may differ, so compare magnitudes.
- **The motion.** The paper's FE figure shows an exemplary motion with first contact at 0.29 s.
  alcove's `reference_motion()` is a reconstruction of it (at rest, contact at 0.29 s, pressed in,
  eased back), not the paper's data. The OCP solution of part 1 is a different motion (found with
  the auxiliary contact), so its first contact time need not be 0.29 s.
- **The RMSE.** The paper's final RMSE (3.32 N, 0.265 N m) is measured against its LS-DYNA model;
  ours against `fe-headrest-2d`. The absolute RMSE scales with the forces of the oracle; the
  relative error (RMSE over the peak) and the trend are what carry over. The campaign's
  `force_rmse` is the error of the force vector, sqrt(mean |F_pred - F_true|^2)
  ([concepts.md](concepts.md)); a mean over fx, fy and fz (fy is zero by construction in the
  planar model), alcove's definition before migration 0007, would be sqrt(3) smaller. The
  paper does not state its definition. Both are measured on the
  campaign's own next trajectory; the held-out validation suite (8 prescribed press motions,
  [concepts.md](concepts.md#the-held-out-validation-suite)) measures the error away from it.
- **The approach.** With the paper's weights (w_T = 1e-4, w_tau = 1e-3 in the approach) our
  optimum spends almost no torque: the head falls onto the cushion and bounces, where the paper's
  figure shows the actuation holding the head against gravity before contact. The cost depends
  on the ratio w_T / w_tau only (scaling both scales the approach's cost); the sweep below shows
  that a ratio of about 1000 (w_T = 1) gives the paper's qualitative behaviour. The paper's
  weights stay the preset `head-headrest-2phase`; `head-headrest-smooth` is the smooth variant.
- **Remedies.** The paper names down-weighting the preliminary data (as the cause of its bias)
  and warm starts from a previous loop as ideas and reports no numbers for them, so part 4
  compares them with our own baseline only.
"""


#: The thresholds of the verdicts (each verdict states its own).
ANGLE_TOL = 0.03  # rad: |max joint angle - 0.15 rad|
HOLD_TOL = 0.25  # mean |tau| before contact within 25 % of the holding torque
REST_TORQUE = 0.01  # N m: "zero" torque in phase 2 (under 1 % of the holding torque)
CONTACT_TIME_TOL = 0.01  # s
SMOOTH_SPEED = 0.3  # rad/s: a smooth approach reaches the cushion slower than this
TREND = -0.5  # Spearman rank correlation of the RMSE with k: "decreasing" below this
REL_RMSE = (1.0, 3.0)  # %: the paper's RMSE over its peak force
UNDER = 0.99  # predicted / true peak: "underestimates" below this


def verdict(rep: Report) -> list[str]:
    """One line per claim of the paper, computed from this run's numbers. Every verdict is
    strict and states its threshold: **agrees** (inside it), **differs** (outside it),
    **calibrated** (we tuned the model to match it, so it is no evidence), **n/a**."""
    f = rep.facts
    out: list[str] = []

    def say(cond: bool | None, text: str, calibrated: bool = False) -> None:
        mark = "calibrated" if calibrated else "n/a" if cond is None else ("agrees" if cond else "differs")
        out.append(f"- **{mark}**: {text}")

    if "angle_max" in f:
        say(
            abs(f["angle_max"] - 0.15) <= ANGLE_TOL,
            f"the joint angle stays within {fmt(f['angle_max'])} rad of the start (paper: about 0.15 rad; "
            f"threshold |difference| <= {ANGLE_TOL} rad). The headrest's place in the model preset sets where the "
            "head stops, so this checks the geometry more than the dynamics.",
        )
        if "torque_before" in f:
            ok = abs(f["torque_before"] / f["hold"] - 1) <= HOLD_TOL
            say(
                ok,
                f"before contact the mean |torque| is {fmt(f['torque_before'])} N m, against {fmt(f['hold'])} N m "
                "that holds the head still at the start (paper's figure: the actuation counteracts gravity before "
                f"contact, about 1.35 N m; threshold: within {HOLD_TOL:.0%} of the holding torque)"
                + ("." if ok else "; with the paper's weights our optimum lets the head fall onto the cushion."),
            )
        else:
            say(None, f"the torque stays within {fmt(f['torque1'])} N m in phase 1 (no FE replay to place contact).")
        say(
            f["torque2"] <= REST_TORQUE,
            f"in phase 2 the torque is at most {fmt(f['torque2'])} N m (paper: zero, the head rests without "
            f"actuation; threshold {REST_TORQUE} N m, under 1 % of the holding torque).",
        )
    if "contact_speed" in f:
        smooth = f["contact_speed"] < SMOOTH_SPEED and int(f["force_peaks"]) == 1
        say(
            smooth,
            f"the OCP solution reaches the cushion at {fmt(f['contact_speed'])} rad/s and its FE replay has "
            f"{int(f['force_peaks'])} force peak(s) (paper's figure: a smooth approach and a single press; threshold: "
            f"< {SMOOTH_SPEED} rad/s and exactly 1 peak)"
            + (
                "."
                if smooth
                else "; the head bounces. The weight sweep below shows why and which weights reproduce the paper's "
                "behaviour (task preset `head-headrest-smooth`)."
            ),
        )
    if "ref_first_contact" in f:
        say(
            abs(f["ref_first_contact"] - 0.29) <= CONTACT_TIME_TOL,
            f"the FE replay of the example motion first touches at {fmt(f['ref_first_contact'])} s (paper: 0.29 s): "
            "`reference_motion()` is built to touch at 0.29 s, so this checks the contact detection only.",
            calibrated=True,
        )
    if "ocp_first_contact" in f:
        say(
            None,
            f"the OCP solution itself reaches the cushion at {fmt(f['ocp_first_contact'])} s; the paper gives 0.29 s "
            "for its example motion, not for its OCP solution.",
        )
    key = "ref" if "ref_peak_force" in f else ("ocp" if "ocp_peak_force" in f else None)
    if key:
        pf, pm = f[f"{key}_peak_force"], f[f"{key}_peak_moment"]
        say(
            None,
            f"peak contact force {fmt(pf)} N (paper: of order 100-300 N): the foam of `fe-headrest-2d` was calibrated "
            "to reach the paper's force range, so this is no agreement.",
            calibrated=True,
        )
        say(
            10.0 <= pm <= 30.0,
            f"peak contact moment about the head COG {fmt(pm)} N m (paper: of order 10-30 N m; threshold: inside "
            "10-30 N m). It follows from the calibrated force and our moment point (the paper does not state its "
            "own), so it is weak evidence.",
        )
    if "trend_force" in f:
        n = int(f["n_iterations"])
        trend = f["trend_force"]
        say(
            None if not math.isfinite(trend) else trend <= TREND,
            f"over {n} iterations the force RMSE has a Spearman rank correlation {fmt(trend)} with k "
            f"(median {fmt(f['first_force'])} N over the first 10 % of iterations, "
            f"{fmt(f['last_force'])} N over the last 10 %; paper: decreasing with spikes; threshold <= {TREND}).",
        )
    if "rel_force_vec" in f:
        lo, hi = REL_RMSE
        say(
            lo <= f["rel_force_vec"] <= hi,
            f"last iteration: force RMSE {fmt(f['rel_force_vec'])} % of the peak force with the vector definition "
            f"sqrt(mean |F_pred - F_true|^2) ({fmt(f['rel_force'])} % with the per-component mean, which is sqrt(3) "
            f"smaller; paper: 3.32 N of 100-300 N, about 1-3 %, its definition not stated; threshold {lo}-{hi} %). "
            "The error is measured on the campaign's own next trajectory, nearly a repeat of earlier ones late in the "
            "loop; the held-out validation suite (section 3) measures the error away from it.",
        )
    if "peak_ratio" in f:
        under = f["peak_ratio"] < UNDER
        say(
            under,
            f"the surrogate's peak force is {fmt(f['peak_ratio'])} times the oracle's on the last trajectory "
            f"(paper: it underestimates high forces, biased by the preliminary data; threshold < {UNDER})"
            f"{'' if under else '; here it does not'}.",
        )
    if "gen_last" in f:
        say(
            None,
            f"on the held-out validation suite (motions no campaign saw, never in the pool) model {int(f['gen_k1'])} "
            f"is off by {fmt(f['gen_last'])} N (vector RMSE; model {int(f['gen_k0'])}: {fmt(f['gen_first'])} N), "
            f"{fmt(f['gen_ratio'])} times its in-loop error: the paper reports no such figure.",
        )
    if "remedy1_mean_force" in f:
        b, d = f["remedy0_mean_force"], f["remedy1_mean_force"]
        out.append(
            f"- remedy, down-weighting: mean force RMSE {fmt(d)} N against the baseline's {fmt(b)} N "
            "over the same iterations "
            f"({'better' if d < b else 'not better'} in this run; one seed, no threshold: not a verdict)."
        )
    if "remedy3_mean_force" in f:
        c, w = f["remedy2_mean_force"], f["remedy3_mean_force"]
        out.append(
            f"- remedy, warm start on an adjusted task: mean force RMSE {fmt(w)} N against {fmt(c)} N "
            "when starting from the preliminary data "
            f"({'better' if w < c else 'not better'} in this run; one seed, no threshold: not a verdict)."
        )
    if not out:
        return []
    note = (
        "Computed from the numbers above. **agrees**: inside the stated threshold; **differs**: outside it; "
        "**calibrated**: we tuned the model to reach it, so it is no evidence; **n/a**: no threshold applies."
    )
    if f.get("n_iterations", 200) < 200:
        note += " The campaign was shortened: it shows the pipeline and the first iterations, not the paper's 200."
    return ["## What this run shows", "", note, "", *out, ""]


def write_markdown(
    rep: Report, info: dict[str, str], args: dict[str, Any], total: float, date: str | None = None
) -> Path:
    """Write OUT/reproduction.md, and OUT/reproduction/run.json with what it is rendered from
    (``scripts/reproduce.py --render-only`` re-renders a page from it with the current verdicts)."""
    date = date or dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M")
    run = {**rep.to_json(), "info": info, "args": args, "total": total, "date": date}
    (rep.out / "reproduction").mkdir(parents=True, exist_ok=True)
    (rep.out / "reproduction" / "run.json").write_text(json.dumps(run, indent=1) + "\n")
    lines = [
        "# Reproduction of the paper",
        "",
        "<!-- generated by scripts/reproduce.py; do not edit by hand -->",
        "",
        "This file is written by `make reproduce` (`scripts/reproduce.py`): it runs the proof of concept of",
        'Fahse et al., "Towards Using Active Learning Methods for Human-Seat Interactions To Generate',
        'Realistic Occupant Motion", end to end with alcove. Every number below comes from that run'
        + (" (except what the `rendered` row below names)." if args.get("rendered") else "."),
        "",
    ]
    if rep.quick:
        lines += [
            "> **Quick smoke run** (`--quick`): aux-penalty oracle, a small preliminary set and few iterations "
            "in the campaigns. The numbers only show that the pipeline works; they are not a reproduction.",
            "",
        ]
    elif args["iterations"] < 200:
        lines += [
            f"> **Shortened run**: {args['iterations']} iterations in the baseline campaign (the paper runs 200) and "
            f"{args['remedy_iterations']} in each remedy campaign. "
            "`make reproduce` without arguments runs the full 200.",
            "",
        ]
    lines += ["## The run", "", "| | |", "|---|---|"]
    lines += [f"| date (UTC) | {date} |"]
    if args.get("rendered"):
        lines += [f"| rendered | {args['rendered']} |"]
    lines += [f"| command | `{args['command']}` |"]
    lines += [
        f"| baseline campaign | {args['iterations']} iterations |",
        f"| each remedy campaign | {args['remedy_iterations']} iterations |",
    ]
    lines += [f"| {k} | {v} |" for k, v in info.items()]
    lines += [f"| campaign steps | {rep.timings_note} |", f"| total wall time | {total:.1f} s |", ""]
    lines += [
        "Wall times (the machine may be shared; they are as measured, under whatever load there was):",
        "",
        "| part | wall time [s] |",
        "|---|---|",
    ]
    lines += [f"| {k} | {v:.2f} |" for k, v in rep.timings.items()]
    lines += [
        "",
        "## Comparison with the paper",
        "",
        "| part | quantity | paper | alcove (this run) | note |",
        "|---|---|---|---|---|",
    ]
    for r in rep.rows:
        cells = (r.section, r.quantity, r.paper, r.cell(), r.note)
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    lines.append("")
    for key, title in SECTION_TITLES.items():
        lines += [f"## {title}", ""]
        if rep.errors.get(key, "").startswith("skipped"):
            lines += ["*Skipped in this run (`--skip`).*", ""]
        elif key in rep.errors:
            lines += ["**This part failed in this run:**", "", "```", rep.errors[key].strip(), "```", ""]
        lines += rep.sections.get(key, [])
        if rep.sections.get(key):
            lines.append("")
        for png, caption in FIGURES[key]:
            if (rep.out / "reproduction" / png).exists():
                lines += [f"![{caption}](reproduction/{png})", "", f"*{caption}*", ""]
    lines += [*verdict(rep), DIFFERENCES]
    path = rep.out / "reproduction.md"
    path.write_text("\n".join(lines))
    return path
