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

/** The field problems a check route answers with (a 422 answer is its result too, not a failure). */
export async function fieldProblems(call: () => Promise<unknown>): Promise<FieldError[]> {
  try {
    return fieldErrors(await call());
  } catch (err) {
    if (err instanceof ApiError && err.status === 422) return err.fieldErrors;
    throw err;
  }
}

/** A bound as people read it: ±π/2 is 1.5708, not 1.5707963267948966 (6 significant digits; whole and short numbers stay as they are). */
export function boundText(x: number | string): string {
  const n = typeof x === "number" ? x : Number(x);
  if (!Number.isFinite(n)) return String(x);
  return String(Number(n.toPrecision(6)));
}

const PYDANTIC: [RegExp, string | ((m: RegExpExecArray) => string)][] = [
  [/^Input should be a valid integer, got a number with a fractional part$/i, "must be a whole number"],
  [/^Input should be a valid integer.*$/i, "must be a whole number"],
  [/^Input should be a valid number.*$/i, "must be a number"],
  [/^Input should be a finite number$/i, "must be a finite number"],
  [/^Field required$/i, "required"],
  [/^Input should be (greater|less) than or equal to (.+)$/i, (m) => `must be at ${m[1].toLowerCase() === "greater" ? "least" : "most"} ${boundText(m[2])}`],
  [/^Input should be (greater|less) than (.+)$/i, (m) => `must be ${m[1].toLowerCase()} than ${boundText(m[2])}`],
  [/^String should have at least 1 characters?$/i, "must not be empty"],
  [/^String should have at least (\d+) characters?$/i, (m) => `must have at least ${m[1]} characters`],
  [/^String should have at most (\d+) characters?$/i, (m) => `must have at most ${m[1]} characters`],
  [/^List should have at least (\d+) items?.*$/i, (m) => `must have at least ${m[1]} item${m[1] === "1" ? "" : "s"}`],
  [/^List should have at most (\d+) items?.*$/i, (m) => `must have at most ${m[1]} item${m[1] === "1" ? "" : "s"}`],
  [/^String should match pattern .*$/i, "has characters that are not allowed"],
  [/^Input should be (.+)$/i, (m) => `must be ${m[1]}`],
  [/^Value error, (.+)$/i, (m) => m[1]],
  [/^Extra inputs are not permitted$/i, "is not a known setting"],
];

/** Pydantic's messages in a form's words ("Input should be a valid number" -> "must be a number"). */
export function humanMessage(message: string): string {
  for (const [re, out] of PYDANTIC) {
    const m = re.exec(message.trim());
    if (m) return typeof out === "string" ? out : out(m);
  }
  return message;
}

/** A dotted path in words where no form labels it: "spec.phases.0.q_min.1" -> "phases 1 › q_min 2". */
export function pathWords(path: string): string {
  return path
    .replace(/^spec\./, "")
    .split(".")
    .reduce<string[]>((out, part) => (/^\d+$/.test(part) && out.length ? [...out.slice(0, -1), `${out[out.length - 1]} ${Number(part) + 1}`] : [...out, part]), [])
    .join(" › ");
}

function describeBody(status: number, body: unknown): string {
  const detail = (body as { detail?: unknown } | null)?.detail;
  if (typeof detail === "string") return detail;
  const fields = fieldErrors(body);
  if (fields.length) return fields.map((f) => (f.field ? `${pathWords(f.field)}: ${humanMessage(f.message)}` : humanMessage(f.message))).join("; ");
  if (status === 0) return "the server cannot be reached";
  return `HTTP ${status}`;
}

export function errorMessage(error: unknown): string {
  if (error instanceof Error) return error.message;
  if (typeof error === "string") return error;
  return "unknown error";
}
