import { useRef, useState, type FormEvent } from "react";
import { useNavigate } from "react-router-dom";
import { downloadFile, useCampaignAction, useForkCampaign, type CampaignDetail } from "../api/hooks";
import { ApiError, errorMessage } from "../api/errors";
import { ConfigSections, type ConfigDraft } from "../pages/NewCampaignPage";

type Action = "start" | "pause" | "resume" | "cancel" | "retry";

/** Which controls make sense in which campaign state (the API still has the last word: 409). */
export function allowedActions(status: string): Action[] {
  switch (status) {
    case "draft":
      return ["start", "cancel"];
    case "queued":
    case "running":
      return ["pause", "cancel"];
    case "pausing":
      return ["cancel"];
    case "paused":
      return ["resume", "cancel", "retry"];
    case "failed":
      return ["retry"];
    default:
      return [];
  }
}

const LABELS: Record<Action, string> = { start: "Start", pause: "Pause", resume: "Resume", cancel: "Cancel", retry: "Retry step" };

export function Controls({ campaign, lastIteration }: { campaign: CampaignDetail; lastIteration: number }) {
  const action = useCampaignAction(campaign.id);
  const fork = useForkCampaign(campaign.id);
  const navigate = useNavigate();
  const dialog = useRef<HTMLDialogElement>(null);
  const [forkFrom, setForkFrom] = useState(lastIteration);
  const [forkName, setForkName] = useState(`${campaign.name} (fork)`);
  const [forkConfig, setForkConfig] = useState<ConfigDraft>(() => structuredClone(campaign.config ?? {}));
  const [forkOpen, setForkOpen] = useState(false);
  const [exportError, setExportError] = useState<string | null>(null);
  const allowed = allowedActions(campaign.status);

  async function submitFork(e: FormEvent) {
    e.preventDefault();
    const { stopping, settings, policies } = forkConfig;
    const created = await fork.mutateAsync({ iteration: forkFrom, name: forkName, stopping, settings, policies });
    dialog.current?.close();
    navigate(`/campaigns/${created.id}`);
  }

  return (
    <div className="toolbar" role="group" aria-label="Campaign controls">
      {(Object.keys(LABELS) as Action[]).map((a) => (
        <button
          key={a}
          type="button"
          className={a === "start" || a === "resume" ? "primary" : a === "cancel" ? "danger" : undefined}
          disabled={!allowed.includes(a) || action.isPending}
          onClick={() => {
            if (a === "cancel" && !confirm("Cancel this campaign? Running jobs stop at their next check.")) return;
            action.mutate(a);
          }}
        >
          {LABELS[a]}
        </button>
      ))}
      <button
        type="button"
        onClick={() => {
          setForkOpen(true);
          dialog.current?.showModal();
        }}
        disabled={lastIteration < 0}
      >
        Fork…
      </button>
      <button
        type="button"
        onClick={() => {
          setExportError(null);
          downloadFile(`/api/v1/campaigns/${campaign.id}/export`, `campaign-${campaign.id}.zip`).catch((err) => setExportError(errorMessage(err)));
        }}
      >
        Export
      </button>
      {action.isError && (
        <span className="error-text" role="alert">
          {errorMessage(action.error)}
        </span>
      )}
      {exportError && (
        <span className="error-text" role="alert">
          Export: {exportError}
        </span>
      )}
      <dialog ref={dialog} aria-labelledby="fork-title" style={{ width: 900, maxWidth: "95vw" }} onClose={() => setForkOpen(false)}>
        {forkOpen && (
        <form onSubmit={submitFork}>
          <h2 id="fork-title">Fork from an iteration</h2>
          <p className="muted">The new campaign starts from this campaign's pool and model at iteration k.</p>
          <div className="field">
            <label htmlFor="fork-k">Iteration k</label>
            <input id="fork-k" type="number" min={0} max={lastIteration} value={forkFrom} onChange={(e) => setForkFrom(Number(e.target.value))} required />
          </div>
          <div className="field">
            <label htmlFor="fork-name">Name</label>
            <input id="fork-name" value={forkName} onChange={(e) => setForkName(e.target.value)} required />
          </div>
          <ConfigSections value={forkConfig} onChange={setForkConfig} errors={fork.error instanceof ApiError ? Object.fromEntries(fork.error.fieldErrors.map((e) => [e.field, e.message])) : {}} only={["stopping", "settings", "policies"]} />
          {fork.isError && (
            <p className="error-text" role="alert">
              {errorMessage(fork.error)}
            </p>
          )}
          <div className="toolbar">
            <button type="submit" className="primary" disabled={fork.isPending}>
              Fork
            </button>
            <button type="button" onClick={() => dialog.current?.close()}>
              Close
            </button>
          </div>
        </form>
        )}
      </dialog>
    </div>
  );
}
