/**
 * A download through the API (with the bearer token): a model artifact, a pool version, a
 * campaign export. Preparing one can take many seconds under load, so while it runs the button
 * says so ("Preparing…", busy, disabled against a second click) and a failure is shown beside it.
 * A download whose model zips a worker builds first (the API answers 202 with the build) shows
 * the build's progress (zips stored of all, what it waits for) and starts when the build is ready.
 */
import { useState } from "react";
import { downloadFile, type ArtifactBuild } from "../api/client";
import { errorMessage } from "../api/errors";

type State = { busy: boolean; error: string | null; build: ArtifactBuild | null };

/** The build's state in words, for the button and screen readers. */
function buildProgress(build: ArtifactBuild): string {
  if (build.status === "ready") return "built, downloading…";
  if (build.status === "running") return `building ${Math.min(build.models_done + 1, build.models_total)} of ${build.models_total}…`;
  return `${build.detail}…`;
}

export function DownloadButton({ path, filename, label, className = "link" }: { path: string; filename: string; label: string; className?: string }) {
  const [state, setState] = useState<State>({ busy: false, error: null, build: null });
  const progress = state.build ? buildProgress(state.build) : "preparing…";
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
          setState({ busy: true, error: null, build: null });
          downloadFile(path, filename, (build) => setState({ busy: true, error: null, build }))
            .then(() => setState({ busy: false, error: null, build: null }))
            .catch((e) => setState({ busy: false, error: errorMessage(e), build: null }));
        }}
      >
        {state.busy ? (
          <>
            <span className="spinner" aria-hidden="true" /> {label}: {progress}
          </>
        ) : (
          label
        )}
      </button>
      {state.busy && state.build && state.build.models_total > 0 && (
        <progress
          className="build-progress"
          max={state.build.models_total}
          value={state.build.models_done}
          aria-label={`${label}: model zips built`}
        />
      )}
      {state.busy && (
        <span className="sr-only" role="status">
          {state.build ? `${filename}: ${progress}` : `Preparing ${filename}; the download starts when it is ready.`}
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
