import type { ReactNode } from "react";
import { errorMessage } from "../api/errors";

export function Loading({ label = "Loading…" }: { label?: string }) {
  return (
    <div className="state loading" role="status" aria-live="polite">
      <span className="spinner" aria-hidden="true" /> {label}
    </div>
  );
}

export function ErrorBox({ error, retry }: { error: unknown; retry?: () => void }) {
  return (
    <div className="state error" role="alert">
      <strong>Something went wrong.</strong> {errorMessage(error)}
      {retry && (
        <button type="button" onClick={retry} className="link">
          Retry
        </button>
      )}
    </div>
  );
}

export function Empty({ title, children }: { title: string; children?: ReactNode }) {
  return (
    <div className="state empty">
      <strong>{title}</strong>
      {children && <div>{children}</div>}
    </div>
  );
}

const STATUS_CLASS: Record<string, string> = {
  running: "info",
  queued: "info",
  succeeded: "ok",
  completed: "ok",
  finished: "ok",
  paused: "warn",
  pausing: "warn",
  quarantined: "warn",
  failed: "bad",
  error: "bad",
  cancelled: "muted",
  cancelling: "muted",
  draft: "muted",
  pending: "muted",
};

export function StatusBadge({ status, title }: { status: string | null | undefined; title?: string }) {
  const s = status ?? "unknown";
  return (
    <span className={`badge ${STATUS_CLASS[s] ?? "muted"}`} title={title}>
      {s}
    </span>
  );
}
