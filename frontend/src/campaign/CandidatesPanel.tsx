/**
 * The iteration view's "Candidates & picks" tab: every candidate scenario the
 * iteration's OCP solved, with its score and rank, which were picked and why (the API derives
 * the why from the acquisition rule), each candidate's OCP trajectory on demand, and the picked
 * trajectories' forces: the ensemble's mean ± 2 std band against the oracle.
 */
import { useMemo, useState } from "react";
import { useQueries, useQuery } from "@tanstack/react-query";
import { candidatesQuery, candidateTrajectoryQuery, pickCurvesQuery } from "./queries";
import type { CandidateDetail, IterationCandidates, IterationCurves } from "../api/types";
import { Plot, type Trace } from "../components/Plot";
import { Empty, ErrorBox, Loading } from "../components/States";
import { fmtNumber } from "../lib/format";
import { scenarioText } from "../lib/scenario";
import { wrenchTraces } from "./ForcesPanel";

export { scenarioText };

const PICKED = "#1d7a45";
const NOT_PICKED = "#a3a9b6";
const FAILED = "#b3261e";

/** Short labels of the API's why codes (the full sentence is the row's text). */
export const WHY_LABEL: Record<string, string> = {
  "picked-top": "picked: top score",
  "picked-far": "picked: next far enough",
  replayed: "picked: every draw replayed",
  "not-converged": "not converged",
  "below-threshold": "below stopping threshold",
  "too-close": "too close to a pick",
  "batch-full": "not in top q",
  "no-contact": "no contact",
  pending: "waiting for the other candidates",
};

export function isPicked(c: CandidateDetail): boolean {
  return c.pick != null;
}


/** The scores as bars by slot: picked green, not picked grey, not converged red (no bar). */
export function scoreTraces(cands: CandidateDetail[]): Trace[] {
  const color = (c: CandidateDetail) => (isPicked(c) ? PICKED : c.converged === false ? FAILED : NOT_PICKED);
  return [
    {
      x: cands.map((c) => `slot ${c.slot}`),
      y: cands.map((c) => c.score ?? 0),
      text: cands.map((c) => `rank ${c.rank ?? "–"}: ${WHY_LABEL[c.why.code] ?? c.why.code}`),
      type: "bar",
      name: "ensemble disagreement [N]",
      marker: { color: cands.map(color) },
    } as unknown as Trace, // a bar trace (in plotly's basic bundle); Trace is typed for scatter
  ];
}

function ScorePlot({ data }: { data: IterationCandidates }) {
  const traces = useMemo(() => scoreTraces(data.candidates), [data.candidates]);
  const shapes = useMemo(
    () =>
      data.min_disagreement != null
        ? [{ type: "line" as const, xref: "paper" as const, x0: 0, x1: 1, y0: data.min_disagreement, y1: data.min_disagreement, line: { color: FAILED, dash: "dot" as const, width: 1 } }]
        : undefined,
    [data.min_disagreement],
  );
  return (
    <Plot
      testId="candidate-scores"
      traces={traces}
      shapes={shapes}
      title={data.min_disagreement != null ? `Scores (dotted: stopping threshold ${fmtNumber(data.min_disagreement)} N)` : "Scores"}
      yTitle="max ensemble force std in contact [N]"
      height={260}
      exportName="candidate-scores"
      extraLayout={{ showlegend: false }}
      data={{ picked: data.candidates.filter(isPicked).sort((a, b) => (a.pick ?? 0) - (b.pick ?? 0)).map((c) => c.slot).join(",") }}
    />
  );
}

type Comp = "fx" | "fy" | "fz" | "mx" | "my" | "mz";

/** The components that are not zero throughout (the planar model's fy, mx, mz are zero by construction). */
export function activeComponents(c: IterationCurves, comps: readonly Comp[]): Comp[] {
  const nonzero = comps.filter((k) => c.truth[k].some((v) => v !== 0) || c.predicted[k].some((v) => v !== 0));
  return nonzero.length ? nonzero : [...comps];
}

function PickForces({ campaignId, iteration, picks }: { campaignId: number; iteration: number; picks: CandidateDetail[] }) {
  const [moment, setMoment] = useState(false);
  const curves = useQueries({ queries: picks.map((c) => pickCurvesQuery(campaignId, iteration, c.pick ?? 0)) });
  const comps = moment ? (["mx", "my", "mz"] as const) : (["fx", "fy", "fz"] as const);
  return (
    <section aria-label="Picked trajectories' forces">
      <div className="toolbar">
        <h3 style={{ margin: 0 }}>Picked trajectories: oracle vs surrogate (ensemble mean ± 2σ)</h3>
        <span className="spacer" />
        <label className="field-inline">
          <input type="checkbox" checked={moment} onChange={(e) => setMoment(e.target.checked)} /> moments
        </label>
      </div>
      <div className="grid2">
        {picks.map((c, i) => {
          const q = curves[i];
          if (q.isPending) return <Loading key={c.slot} label={`Loading pick ${(c.pick ?? 0) + 1}…`} />;
          if (q.isError) return <ErrorBox key={c.slot} error={q.error} />;
          return (
            <figure key={c.slot} style={{ margin: 0 }}>
              <figcaption className="muted">
                pick {(c.pick ?? 0) + 1} (slot {c.slot}){c.force_rmse != null ? `: force RMSE ${fmtNumber(c.force_rmse)} N` : ""}
              </figcaption>
              <Plot
                testId="pick-forces"
                traces={wrenchTraces([q.data], activeComponents(q.data, comps))}
                xTitle="t [s]"
                yTitle={moment ? "moment [N m]" : "force [N]"}
                height={300}
                exportName={`iteration-${iteration}-pick-${(c.pick ?? 0) + 1}`}
                data={{ pick: String(c.pick), band: q.data.std ? "true" : "false" }}
              />
            </figure>
          );
        })}
      </div>
    </section>
  );
}

function CandidateTrajectories({ campaignId, iteration, slots }: { campaignId: number; iteration: number; slots: number[] }) {
  const trajectories = useQueries({ queries: slots.map((j) => candidateTrajectoryQuery(campaignId, iteration, j)) });
  const traces: Trace[] = trajectories.flatMap((t, i) => (t.data ? t.data.q.map((qj, j) => ({ x: t.data.t, y: qj, name: `slot ${slots[i]} q${j}`, mode: "lines", type: "scatter" }) as Trace) : []));
  const failed = trajectories.find((t) => t.isError);
  return (
    <>
      {failed && <ErrorBox error={failed.error} />}
      <Plot testId="candidate-trajectories" traces={traces} title="Candidates' OCP solutions" xTitle="t [s]" yTitle="joint angle [rad]" height={260} exportName={`iteration-${iteration}-candidates`} data={{ slots: slots.join(",") }} />
    </>
  );
}

export function CandidatesTable({ data, shown, toggle }: { data: IterationCandidates; shown: number[]; toggle: (slot: number) => void }) {
  const ranked = [...data.candidates].sort((a, b) => (a.rank ?? 1e9) - (b.rank ?? 1e9) || a.slot - b.slot);
  return (
    <table data-testid="candidates-table">
      <thead>
        <tr>
          <th>rank</th>
          <th>slot</th>
          <th>score [N]</th>
          <th>pick</th>
          <th>why</th>
          <th>scenario</th>
          <th>force RMSE [N]</th>
          <th>OCP</th>
        </tr>
      </thead>
      <tbody>
        {ranked.map((c) => (
          <tr key={c.slot} data-slot={c.slot} data-picked={isPicked(c)} data-why={c.why.code}>
            <td>{c.rank ?? "–"}</td>
            <td>{c.slot}</td>
            <td>{c.score != null ? fmtNumber(c.score) : "–"}</td>
            <td>{c.pick != null ? c.pick + 1 : "–"}</td>
            <td>
              <span className="why-code" data-picked={isPicked(c)}>
                {WHY_LABEL[c.why.code] ?? c.why.code}
              </span>{" "}
              <span className="muted">{c.why.text}</span>
            </td>
            <td className="muted">{scenarioText(c.scenario)}</td>
            <td>{c.force_rmse != null ? fmtNumber(c.force_rmse) : "–"}</td>
            <td>
              {c.ocp_solution_id != null ? (
                <label className="field-inline">
                  <input type="checkbox" checked={shown.includes(c.slot)} onChange={() => toggle(c.slot)} aria-label={`show the OCP solution of slot ${c.slot}`} />
                  {c.converged ? "converged" : "not converged"}
                </label>
              ) : (
                "–"
              )}
            </td>
          </tr>
        ))}
      </tbody>
    </table>
  );
}

const POLL_MS = 3000;

/** Whether an iteration's candidates will not change any more: no candidate waits for the
 * others, every pick's curves are stored (or there is no pick). Until then the tab polls. */
export function settled(data: IterationCandidates | undefined): boolean {
  if (!data) return false;
  if (data.strategy === "paper") return true;
  if (data.candidates.length < data.n_candidates || data.candidates.some((c) => c.why.code === "pending")) return false;
  return data.candidates.every((c) => !isPicked(c) || c.has_curves);
}

/** Which iteration the tab shows (also one without metrics, e.g. one the stopping rule ended). */
function IterationPicker({ iteration, last, setIteration }: { iteration: number | null; last: number; setIteration?: (k: number) => void }) {
  if (!setIteration || last < 1) return null;
  return (
    <label className="field-inline">
      iteration{" "}
      <input
        type="number"
        min={1}
        max={last}
        step={1}
        value={iteration ?? ""}
        style={{ width: "6em" }}
        onChange={(e) => {
          const k = Number(e.target.value);
          if (Number.isInteger(k) && k >= 1 && k <= last) setIteration(k);
        }}
        aria-label="iteration of the candidates"
      />
      {" "}
      <span className="muted">of {last}</span>
    </label>
  );
}

export function CandidatesPanel({ campaignId, iteration, last = 0, setIteration }: { campaignId: number; iteration: number | null; last?: number; setIteration?: (k: number) => void }) {
  const picker = <IterationPicker iteration={iteration} last={last} setIteration={setIteration} />;
  return (
    <>
      <div className="toolbar">{picker}</div>
      <CandidatesOf campaignId={campaignId} iteration={iteration} />
    </>
  );
}

function CandidatesOf({ campaignId, iteration }: { campaignId: number; iteration: number | null }) {
  const q = useQuery({ ...candidatesQuery(campaignId, iteration ?? 0), enabled: iteration !== null && iteration > 0, refetchInterval: (query) => (settled(query.state.data) ? false : POLL_MS) });
  const [shown, setShown] = useState<number[]>([]);
  if (iteration === null || iteration === 0) return <Empty title="No iteration with candidates yet">Candidates appear once an iteration's OCP has solved them.</Empty>;
  if (q.isPending) return <Loading label="Loading candidates…" />;
  if (q.isError) return <ErrorBox error={q.error} retry={() => void q.refetch()} />;
  const data = q.data;
  if (!data.candidates.length)
    return (
      <Empty title={`Iteration ${iteration} has no candidates`}>
        {data.strategy === "paper" ? "Strategy paper solves the task as written: one trajectory per iteration (see the Forces tab)." : "Its OCP has not solved any candidate yet."}
      </Empty>
    );
  const picks = data.candidates.filter((c) => isPicked(c) && c.has_curves).sort((a, b) => (a.pick ?? 0) - (b.pick ?? 0));
  const toggle = (slot: number) => setShown((s) => (s.includes(slot) ? s.filter((x) => x !== slot) : [...s, slot]));
  return (
    <div data-testid="candidates-panel" data-iteration={iteration}>
      <p className="muted" data-testid="candidates-summary">
        Iteration {iteration}: strategy {data.strategy}, {data.candidates.length} of {data.n_candidates} candidates solved, {data.candidates.filter(isPicked).length} picked (q = {data.batch})
        {data.min_distance != null ? `, min distance ${fmtNumber(data.min_distance)}` : ""}
        {data.top_score != null ? `, top score ${fmtNumber(data.top_score)} N` : ""}.
      </p>
      {data.candidates.some((c) => c.score != null) && <ScorePlot data={data} />}
      <CandidatesTable data={data} shown={shown} toggle={toggle} />
      {shown.length > 0 && <CandidateTrajectories campaignId={campaignId} iteration={iteration} slots={shown} />}
      {picks.length > 0 ? <PickForces campaignId={campaignId} iteration={iteration} picks={picks} /> : <p className="muted">No picked trajectory has been evaluated yet.</p>}
    </div>
  );
}
