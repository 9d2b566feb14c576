/** A form's error display: the problems no field owns (with their full labels) and any other failure, once each. */
import { ApiError, errorMessage, type FieldError } from "../api/errors";
import type { ErrorView } from "../lib/formErrors";

/** The field problems of a failed request (422), or none. */
export function serverProblems(error: unknown): FieldError[] {
  return error instanceof ApiError && error.status === 422 ? error.fieldErrors : [];
}

/** A failure that is not a list of field problems (409, 500, network...), as one message; else null. */
export function generalFailure(error: unknown): string | null {
  if (!error) return null;
  if (serverProblems(error).length) return null;
  return errorMessage(error);
}

export function FormErrors({ view, failure }: { view: ErrorView; failure?: unknown }) {
  const general = generalFailure(failure);
  if (!view.unplaced.length && !general) return null;
  return (
    <div className="error-text" role="alert" data-testid="form-errors">
      {general && <p data-testid="form-failure">{general}</p>}
      {view.unplaced.length > 0 && (
        <ul>
          {view.unplaced.map((p) => (
            <li key={p.path} className="field-error" data-error-path={p.path}>
              {p.label ? `${p.label}: ` : ""}
              {p.message}
            </li>
          ))}
        </ul>
      )}
    </div>
  );
}

/** The count badge: the number of problems the form shows. */
export function ErrorCount({ view, checking = false }: { view: ErrorView; checking?: boolean }) {
  const n = view.problems.length;
  return (
    <span className={n ? "badge bad" : "badge ok"} data-testid="check-state" data-count={n} aria-live="polite">
      {checking ? "checking…" : n ? `${n} problem${n === 1 ? "" : "s"}` : "valid"}
    </span>
  );
}
