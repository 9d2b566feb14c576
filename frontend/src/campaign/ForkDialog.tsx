import { useState, type FormEvent } from "react";
import { useNavigate } from "react-router-dom";
import { maxIterations, useForkCampaign } from "./queries";
import type { CampaignOut } from "../api/types";
import { ConfigSections, configFieldPaths, configLabel, configLocalErrors, type ConfigDraft } from "./ConfigSections";
import { FormErrors, serverProblems } from "../components/FormErrors";
import { FieldMessages } from "../components/SchemaForm";
import { useOpenApi } from "../api/definitions";
import { cleanName, errorView, nameProblems } from "../lib/formErrors";
import { NumberInput, type NumberText } from "../components/NumberInput";
import type { FieldError } from "../api/errors";

const ONLY = ["stopping", "settings", "policies"] as const;

/** Further iterations a fork runs by default when the source has none left (it reached its limit). */
export const DEFAULT_FURTHER = 10;

/**
 * The fork's defaults: fork at the latest finished iteration k and run the iterations the
 * source had left, or DEFAULT_FURTHER more if it had reached its limit (max_iterations = k + n,
 * so the fork never starts past its own limit).
 */
export function forkDefaults(campaign: CampaignOut, lastIteration: number): { k: number; further: number } {
  const k = Math.max(lastIteration, 0);
  const max = maxIterations(campaign);
  const left = max !== null ? max - k : 0;
  return { k, further: left > 0 ? left : DEFAULT_FURTHER };
}

export function ForkDialog({ campaign, lastIteration, close }: { campaign: CampaignOut; lastIteration: number; close: () => void }) {
  const fork = useForkCampaign(campaign.id);
  const navigate = useNavigate();
  const defaults = forkDefaults(campaign, lastIteration);
  const [k, setK] = useState<NumberText>(defaults.k);
  const [further, setFurther] = useState<NumberText>(defaults.further);
  const [name, setName] = useState(`${campaign.campaign.name} (fork at ${defaults.k})`);
  const [start, setStart] = useState(true);
  const [config, setConfig] = useState<ConfigDraft>(() => {
    const c = structuredClone(campaign.config ?? {}) as ConfigDraft;
    c.stopping = { ...c.stopping, max_iterations: defaults.k + defaults.further };
    return c;
  });
  const openapi = useOpenApi();
  // the form as the last fork request sent it: the server's problems apply while the form still shows it
  const draftKey = JSON.stringify([k, further, name, start, config]);
  const [sentKey, setSentKey] = useState<string | null>(null);
  const local: FieldError[] = [...configLocalErrors(openapi.data, config, ONLY)];
  local.push(...nameProblems(name));
  if (typeof k !== "number" || !Number.isInteger(k) || k < 0 || k > lastIteration) local.push({ field: "iteration", message: `must be a whole number from 0 to ${lastIteration}` });
  if (typeof further !== "number" || !Number.isInteger(further) || further < 1) local.push({ field: "further", message: "must be a whole number of at least 1" });
  const own: Record<string, string> = { iteration: "Fork after iteration k", further: "Further iterations", name: "Name" };
  const errors = errorView([local, sentKey === draftKey ? serverProblems(fork.error) : []], [...Object.keys(own), ...configFieldPaths(openapi.data, ONLY)], (p) => own[p] ?? configLabel(openapi.data, p));
  const limit = Number(config.stopping?.max_iterations ?? NaN);

  const setLimit = (newK: number, n: number) => setConfig((c) => ({ ...c, stopping: { ...c.stopping, max_iterations: newK + n } }));

  function submit(e: FormEvent) {
    e.preventDefault();
    if (local.length || typeof k !== "number") return;
    setSentKey(draftKey);
    const { stopping, settings, policies } = config;
    fork.mutate({ iteration: k, name: cleanName(name), start, stopping, settings, policies } as Parameters<typeof fork.mutate>[0], {
      onSuccess: (created) => {
        close();
        navigate(`/campaigns/${created.id}`);
      },
    });
  }

  return (
    <form onSubmit={submit} noValidate>
      <h2 id="fork-title">Fork from an iteration</h2>
      <p className="muted" data-testid="fork-explanation">
        A fork is a new campaign that starts from this campaign&apos;s pool and surrogate model as they were after iteration k, and continues the loop from
        iteration k + 1 with the settings below. This campaign is not changed; the fork&apos;s plot shows iterations up to k greyed, as inherited.
      </p>
      <div className="row">
        <div className="field">
          <label htmlFor="fork-k">Fork after iteration k</label>
          <NumberInput
            id="fork-k"
            inputMode="numeric"
            value={k}
            onChange={(v) => {
              setK(v);
              if (typeof v === "number" && Number.isInteger(v) && typeof further === "number") setLimit(v, further);
            }}
            required
            aria-invalid={errors.at("iteration").length > 0}
          />
          <small className="hint">0 to {lastIteration} (the latest finished iteration)</small>
          <FieldMessages problems={errors.at("iteration")} />
        </div>
        <div className="field">
          <label htmlFor="fork-further">Further iterations</label>
          <NumberInput
            id="fork-further"
            inputMode="numeric"
            value={further}
            onChange={(v) => {
              setFurther(v);
              if (typeof v === "number" && Number.isInteger(v) && typeof k === "number") setLimit(k, v);
            }}
            aria-invalid={errors.at("further").length > 0}
          />
          <small className="hint" data-testid="fork-limit">
            {Number.isFinite(limit) && typeof k === "number" ? `the fork runs iterations ${k + 1} to ${limit} (stopping rule max_iterations = ${limit})` : "no iteration limit"}
          </small>
          <FieldMessages problems={errors.at("further")} />
        </div>
        <div className="field grow">
          <label htmlFor="fork-name">Name</label>
          <input id="fork-name" value={name} onChange={(e) => setName(e.target.value)} required aria-invalid={errors.at("name").length > 0} />
          <FieldMessages problems={errors.at("name")} />
        </div>
      </div>
      <label className="field-inline">
        <input type="checkbox" checked={start} onChange={(e) => setStart(e.target.checked)} /> Start right away
      </label>
      <ConfigSections value={config} onChange={setConfig} errors={errors} only={ONLY} />
      <FormErrors view={errors} failure={fork.error} />
      <div className="toolbar">
        <button type="submit" className="primary" disabled={fork.isPending}>
          Fork
        </button>
        <button type="button" onClick={close}>
          Close
        </button>
      </div>
    </form>
  );
}
