/**
 * A download through the API (with the bearer token): a model artifact, a pool version, a
 * campaign export. Preparing one can take many seconds under load, so while it runs the button
 * says so ("Preparing…", busy, disabled against a second click) and a failure is shown beside it.
 */
import { useState } from "react";
import { downloadFile } from "../api/client";
import { errorMessage } from "../api/errors";

export function DownloadButton({ path, filename, label, className = "link" }: { path: string; filename: string; label: string; className?: string }) {
  const [state, setState] = useState<{ busy: boolean; error: string | null }>({ busy: false, error: null });
  return (
    <>
      <button
        type="button"
        className={className}
        disabled={state.busy}
        aria-busy={state.busy}
        data-busy={state.busy}
        title={state.busy ? `Preparing ${filename}…` : `Download ${filename}`}
        onClick={() => {
          setState({ busy: true, error: null });
          downloadFile(path, filename)
            .then(() => setState({ busy: false, error: null }))
            .catch((e) => setState({ busy: false, error: errorMessage(e) }));
        }}
      >
        {state.busy ? (
          <>
            <span className="spinner" aria-hidden="true" /> {label}: preparing…
          </>
        ) : (
          label
        )}
      </button>
      {state.busy && (
        <span className="sr-only" role="status">
          Preparing {filename}; the download starts when it is ready.
        </span>
      )}
      {state.error && (
        <span className="error-text" role="alert">
          {label}: {state.error}
        </span>
      )}
    </>
  );
}
