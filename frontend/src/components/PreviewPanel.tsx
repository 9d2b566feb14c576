/**
 * The state of an editor preview run by a worker: waiting for the job queue or a worker, running, failed (with
 * the worker's reason) or the result, rendered by the editor. Polls until the preview is final.
 */
import type { ReactNode } from "react";
import { usePreview } from "../api/previews";
import type { Preview } from "../api/types";
import { ErrorBox, Loading, StatusBadge } from "./States";

export function PreviewPanel<R>({
  id,
  title,
  startError,
  render,
}: {
  /** the preview to show (null: none asked for yet) */
  id: number | null;
  title: string;
  /** why asking for the preview failed (422 bad input, 429 too many pending, ...) */
  startError?: unknown;
  render: (result: R, preview: Preview) => ReactNode;
}) {
  const q = usePreview(id);
  if (!startError && id === null) return null;
  const p = q.data;
  let body: ReactNode;
  if (startError) body = <ErrorBox error={startError} />;
  else if (q.isError) body = <ErrorBox error={q.error} retry={() => void q.refetch()} />;
  else if (!p) body = <Loading label="Asking for a preview…" />;
  // what it waits for, from the API: the job queue (broker unreachable: it is sent when it is back) or a worker
  else if (p.status === "pending") body = <Loading label={capitalized(p.status_detail ?? "waiting for a worker") + "…"} />;
  else if (p.status === "running") body = <Loading label={`Running on ${p.worker_name ?? "a worker"}…`} />;
  else if (p.status === "failed")
    body = (
      <div className="state error" role="alert">
        <strong>The preview failed.</strong> {p.error ?? "The worker gave no reason."}
      </div>
    );
  else if (p.result) body = render(p.result as R, p);
  else body = <ErrorBox error={new Error("the preview succeeded without a result")} />;
  return (
    <section className="panel" aria-labelledby="preview-title" data-testid="preview-panel" data-status={startError ? "error" : (p?.status ?? "starting")}>
      <div className="toolbar">
        <h2 id="preview-title" style={{ margin: 0 }}>
          {title}
        </h2>
        {p && <StatusBadge status={p.status} />}
        {p?.draft && <span className="muted">unsaved edit</span>}
      </div>
      {body}
    </section>
  );
}

function capitalized(text: string): string {
  return text.charAt(0).toUpperCase() + text.slice(1);
}
