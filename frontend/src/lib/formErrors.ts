/**
 * Field errors of a form, placed once each: every problem is shown at the field that owns its
 * path (a list field owns its items: `phases.0.q_min.1` belongs to the field `phases.0.q_min`),
 * or, if no field owns it, once in the form's summary. The count the form shows is the number
 * of problems, so badge and messages agree. Labels are human-readable, taken from the schema.
 */
import { resolveRef, unwrapNullable, type JsonSchema } from "./jsonSchema";
import { humanMessage, type FieldError } from "../api/errors";
export { humanMessage };

export interface Problem {
  /** dotted path relative to the form, e.g. "phases.0.q_min.1" */
  path: string;
  message: string;
  /** e.g. "Phase 1 › joint lower bounds in this phase (q_min) 2" */
  label: string;
  /** the field that shows it, or null: the summary does */
  field: string | null;
}

export interface ErrorView {
  problems: Problem[];
  at(field: string): Problem[];
  unplaced: Problem[];
}

/** A field's name in messages: its description's first clause and its name, e.g. "phase duration [s] (duration)". */
export function fieldLabel(name: string, schema: JsonSchema | undefined): string {
  const d = schema?.description?.split(/;|\(default|\. /)[0].trim();
  return d ? `${d} (${name})` : (schema?.title ?? name);
}

function singular(title: string): string {
  return title.endsWith("s") ? title.slice(0, -1) : title;
}

/** The label of a path in a schema: objects by field label, list items by number (from 1). */
export function schemaLabel(root: JsonSchema, path: string): string {
  const parts = path.split(".").filter(Boolean);
  const out: string[] = [];
  let s: JsonSchema | undefined = root;
  for (let i = 0; i < parts.length; i++) {
    const part = parts[i];
    const cur: JsonSchema | undefined = s ? unwrapNullable(s, root).schema : undefined;
    if (cur?.type === "array" || /^\d+$/.test(part)) {
      const n = Number(part) + 1;
      const items: JsonSchema | undefined = cur?.items ? unwrapNullable(cur.items, root).schema : undefined;
      const title = out.pop();
      if (items?.properties) out.push(`${singular(cur?.title ?? title ?? "item")} ${n}`);
      else out.push(`${title ?? "item"} ${n}`);
      s = items;
      continue;
    }
    const prop: JsonSchema | undefined = cur?.properties?.[part];
    out.push(fieldLabel(part, prop ? resolveRef(prop, root) : undefined));
    s = prop;
  }
  return out.join(" › ");
}

/** The field that owns a path: the longest known field path equal to it or above it. */
export function owner(path: string, known: readonly string[]): string | null {
  let best: string | null = null;
  for (const f of known) if ((path === f || path.startsWith(`${f}.`)) && (best === null || f.length > best.length)) best = f;
  return best;
}

/**
 * Merge the sources (earlier ones win for the same path: the form's own checks before the
 * server's), drop duplicates, place each problem at its field.
 */
export function errorView(sources: FieldError[][], known: readonly string[], label: (path: string) => string): ErrorView {
  const byPath = new Map<string, Problem>();
  for (const source of sources) {
    const seen = new Set<string>();
    for (const e of source) {
      const path = e.field;
      if (byPath.has(path) && !seen.has(path)) continue; // an earlier source already said something here
      seen.add(path);
      const message = humanMessage(e.message);
      const prev = byPath.get(path);
      if (prev && prev.message.split("; ").includes(message)) continue;
      byPath.set(path, prev ? { ...prev, message: `${prev.message}; ${message}` } : { path, message, label: path ? label(path) : "", field: owner(path, known) });
    }
  }
  const problems = [...byPath.values()];
  return {
    problems,
    at: (field) => problems.filter((p) => p.field === field),
    unplaced: problems.filter((p) => p.field === null),
  };
}

export const noErrors: ErrorView = { problems: [], at: () => [], unplaced: [] };

/** The problem as shown at its field: the message alone, or with the item it concerns ("joint 2: ..." in a list of joint values). */
export function atFieldText(p: Problem, item = "item"): string {
  if (p.field === null || p.path === p.field) return p.message;
  const rest = p.path.slice(p.field.length + 1).split(".");
  return `${rest.map((x) => (/^\d+$/.test(x) ? `${item} ${Number(x) + 1}` : x)).join(" › ")}: ${p.message}`;
}

/** Re-root paths: the problems under `prefix.` without it (others dropped). */
export function under(errors: FieldError[], prefix: string): FieldError[] {
  return errors.filter((e) => e.field.startsWith(`${prefix}.`)).map((e) => ({ ...e, field: e.field.slice(prefix.length + 1) }));
}

/** A name as it is saved: without leading and trailing spaces (the API trims it too). */
export function cleanName(name: string): string {
  return name.trim();
}

/** The form's check of a name field: a name made only of spaces is no name. */
export function nameProblems(name: string, field = "name", max = 200): FieldError[] {
  const n = cleanName(name);
  if (!n) return [{ field, message: "must not be empty (spaces alone are no name)" }];
  if (n.length > max) return [{ field, message: `must have at most ${max} characters` }];
  return [];
}
