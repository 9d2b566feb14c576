/** Errors as the API sends them (FastAPI: {detail: string} or {detail: [{loc, msg}]}). */
export interface FieldError {
  /** dotted field path without the leading "body"/"query" part, e.g. "phases.0.duration" */
  field: string;
  message: string;
}

export class ApiError extends Error {
  readonly status: number;
  readonly body: unknown;
  constructor(status: number, body: unknown) {
    super(describeBody(status, body));
    this.status = status;
    this.body = body;
  }
  get fieldErrors(): FieldError[] {
    return fieldErrors(this.body);
  }
}

const LOCATION_PREFIXES = new Set(["body", "query", "path", "header"]);

export function fieldErrors(body: unknown): FieldError[] {
  const raw = (body as { detail?: unknown; errors?: unknown } | null | undefined) ?? {};
  const list = Array.isArray(raw.detail) ? raw.detail : Array.isArray(raw.errors) ? raw.errors : [];
  return list.map((e: { loc?: unknown[]; field?: string; path?: string; msg?: string; message?: string; reason?: string }) => {
    let loc: string;
    if (typeof e.field === "string") {
      loc = e.field;
    } else if (Array.isArray(e.loc)) {
      const parts = e.loc.map(String);
      loc = (LOCATION_PREFIXES.has(parts[0]) ? parts.slice(1) : parts).join(".");
    } else {
      loc = e.path ?? "";
    }
    return { field: loc, message: e.msg ?? e.message ?? e.reason ?? "invalid" };
  });
}

function describeBody(status: number, body: unknown): string {
  const detail = (body as { detail?: unknown } | null)?.detail;
  if (typeof detail === "string") return detail;
  const fields = fieldErrors(body);
  if (fields.length) return fields.map((f) => (f.field ? `${f.field}: ${f.message}` : f.message)).join("; ");
  if (status === 0) return "the server cannot be reached";
  return `HTTP ${status}`;
}

export function errorMessage(error: unknown): string {
  if (error instanceof Error) return error.message;
  if (typeof error === "string") return error;
  return "unknown error";
}
