import { useRef, useState } from "react";
import { useCampaignAction, type Action } from "./queries";
import { DownloadButton } from "../components/DownloadButton";
import type { CampaignOut } from "../api/types";
import { errorMessage } from "../api/errors";
import { ForkDialog } from "./ForkDialog";

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

export function Controls({ campaign, lastIteration }: { campaign: CampaignOut; lastIteration: number }) {
  const action = useCampaignAction(campaign.id);
  const dialog = useRef<HTMLDialogElement>(null);
  const [forkOpen, setForkOpen] = useState(false);
  const allowed = allowedActions(campaign.campaign.status);

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
      <DownloadButton path={`/api/v1/campaigns/${campaign.id}/export`} filename={`campaign-${campaign.id}.zip`} label="Export" className="" />
      {action.isError && (
        <span className="error-text" role="alert">
          {errorMessage(action.error)}
        </span>
      )}
      <dialog ref={dialog} aria-labelledby="fork-title" style={{ width: 900, maxWidth: "95vw" }} onClose={() => setForkOpen(false)}>
        {forkOpen && <ForkDialog campaign={campaign} lastIteration={lastIteration} close={() => dialog.current?.close()} />}
      </dialog>
    </div>
  );
}
