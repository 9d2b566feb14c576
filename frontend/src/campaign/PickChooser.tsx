/**
 * The Forces tab's choice of pick: a batch iteration (q > 1) replayed q picked
 * trajectories; the tab shows one of them, pick 1 by default, labelled with its scenario's
 * values, and that pick's OCP solve. An iteration of a q = 1 campaign has no choice.
 */
import { useQuery } from "@tanstack/react-query";
import { candidatesQuery, candidateTrajectoryQuery } from "./queries";
import type { CandidateDetail } from "../api/types";
import type { MetricPoint } from "../lib/metrics";
import { fmtNumber } from "../lib/format";
import { scenarioText } from "../lib/scenario";

export type PickRef = NonNullable<MetricPoint["picks"]>[number];

/** The picks of a batch iteration in pick order; empty for a single pick (q = 1, or a paper iteration). */
export function batchPicks(point: MetricPoint | undefined): PickRef[] {
  const picks = [...(point?.picks ?? [])].sort((a, b) => a.pick - b.pick);
  return picks.length > 1 ? picks : [];
}

/** "pick 2: initial.q.0 = 0.21, …": a pick by its order (from 1) and its scenario's values. */
export function pickLabel(p: PickRef, candidate: CandidateDetail | undefined): string {
  const head = `pick ${p.pick + 1}`;
  return candidate ? `${head}: ${scenarioText(candidate.scenario)}` : `${head} (slot ${p.slot})`;
}

/** The chosen pick's OCP solve in one line (the slot's latest attempt). */
function PickOcp({ campaignId, iteration, slot }: { campaignId: number; iteration: number; slot: number }) {
  const q = useQuery(candidateTrajectoryQuery(campaignId, iteration, slot));
  if (!q.data) return null;
  const s = q.data.solver;
  return (
    <small className="muted" data-testid="pick-ocp">
      OCP of slot {slot}: {s.converged ? "converged" : `not converged (${s.status})`}
      {s.iterations != null ? `, ${s.iterations} IPOPT iterations` : ""}
      {s.cost != null ? `, cost ${fmtNumber(s.cost, 4)}` : ""}
      {s.wall_time_s != null ? `, ${fmtNumber(s.wall_time_s, 3)} s` : ""}
    </small>
  );
}

export function PickChooser({ campaignId, iteration, picks, pick, setPick }: { campaignId: number; iteration: number; picks: PickRef[]; pick: number; setPick: (pick: number) => void }) {
  const candidates = useQuery({ ...candidatesQuery(campaignId, iteration), enabled: picks.length > 1 });
  if (picks.length < 2) return null;
  const bySlot = new Map((candidates.data?.candidates ?? []).map((c) => [c.slot, c]));
  const chosen = picks.find((p) => p.pick === pick) ?? picks[0];
  return (
    <span className="toolbar" data-testid="pick-chooser">
      <label className="field-inline">
        Pick
        <select value={chosen.pick} onChange={(e) => setPick(Number(e.target.value))} aria-label="picked trajectory shown">
          {picks.map((p) => (
            <option key={p.pick} value={p.pick}>
              {pickLabel(p, bySlot.get(p.slot))}
            </option>
          ))}
        </select>
      </label>
      <span className="muted">of {picks.length}</span>
      <PickOcp campaignId={campaignId} iteration={iteration} slot={chosen.slot} />
    </span>
  );
}
