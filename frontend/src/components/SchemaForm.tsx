/**
 * A parameter form generated from a JSON Schema as pydantic emits it: numbers, integers,
 * strings, booleans, enums, nullable fields (anyOf [.., null]), nested objects ($ref to
 * $defs) and arrays of numbers. Field errors (dotted paths) are shown next to their input.
 */
import { useId } from "react";
import type { FieldError } from "../api/errors";
import { atFieldText, noErrors, type ErrorView, type Problem } from "../lib/formErrors";
import { resolveRef, unwrapNullable, type JsonSchema } from "../lib/jsonSchema";
import { NumberInput, readNumber } from "./NumberInput";
import { boundText } from "../api/errors";

export { resolveRef, unwrapNullable, type JsonSchema };

type Values = Record<string, unknown>;

/** Default values of every property (recursing into nested objects). */
export function schemaDefaults(schema: JsonSchema, root: JsonSchema = schema): Values {
  const s = resolveRef(schema, root);
  const out: Values = {};
  for (const [key, prop] of Object.entries(s.properties ?? {})) {
    const { schema: p } = unwrapNullable(prop, root);
    if (prop.default !== undefined) out[key] = prop.default;
    else if (p.default !== undefined) out[key] = p.default;
    else if (p.type === "object" && p.properties) out[key] = schemaDefaults(p, root);
  }
  return out;
}

export function primaryType(s: JsonSchema): string {
  if (s.enum) return "enum";
  if (s.const !== undefined) return "const";
  const t = Array.isArray(s.type) ? s.type.find((x) => x !== "null") : s.type;
  if (t) return t;
  if (s.properties) return "object";
  return "json";
}

function bounds(s: JsonSchema): string {
  const parts: string[] = [];
  if (s.minimum !== undefined) parts.push(`≥ ${boundText(s.minimum)}`);
  if (s.exclusiveMinimum !== undefined) parts.push(`> ${boundText(s.exclusiveMinimum)}`);
  if (s.maximum !== undefined) parts.push(`≤ ${boundText(s.maximum)}`);
  if (s.exclusiveMaximum !== undefined) parts.push(`< ${boundText(s.exclusiveMaximum)}`);
  return parts.join(", ");
}

/** The paths of the fields a form generated from `schema` shows (objects are groups, not fields). */
export function schemaFieldPaths(schema: JsonSchema, root: JsonSchema = schema, prefix = ""): string[] {
  const s = resolveRef(schema, root);
  const out: string[] = [];
  for (const [k, prop] of Object.entries(s.properties ?? {})) {
    const { schema: p } = unwrapNullable(prop, root);
    const path = prefix ? `${prefix}.${k}` : k;
    if (primaryType(p) === "object" && p.properties) out.push(...schemaFieldPaths(p, root, path));
    else out.push(path);
  }
  return out;
}

/** The checks the form makes itself: a number that is no number, a fraction in a whole-number field, the schema's bounds. */
export function numberProblem(v: unknown, s: JsonSchema, integer: boolean): string | null {
  if (v === undefined || v === null || v === "") return null;
  if (typeof v !== "number" || Number.isNaN(v)) return "must be a number";
  if (!Number.isFinite(v)) return "must be a finite number";
  if (integer && !Number.isInteger(v)) return "must be a whole number";
  if (s.minimum !== undefined && v < s.minimum) return `must be at least ${boundText(s.minimum)}`;
  if (s.exclusiveMinimum !== undefined && v <= s.exclusiveMinimum) return `must be greater than ${boundText(s.exclusiveMinimum)}`;
  if (s.maximum !== undefined && v > s.maximum) return `must be at most ${boundText(s.maximum)}`;
  if (s.exclusiveMaximum !== undefined && v >= s.exclusiveMaximum) return `must be less than ${boundText(s.exclusiveMaximum)}`;
  return null;
}

export function schemaLocalErrors(schema: JsonSchema, value: Values | undefined, root: JsonSchema = schema, prefix = ""): FieldError[] {
  const s = resolveRef(schema, root);
  const out: FieldError[] = [];
  for (const [k, prop] of Object.entries(s.properties ?? {})) {
    const { schema: p } = unwrapNullable(prop, root);
    const path = prefix ? `${prefix}.${k}` : k;
    const v = value?.[k];
    const t = primaryType(p);
    if (t === "object" && p.properties) out.push(...schemaLocalErrors(p, v as Values | undefined, root, path));
    else if (t === "number" || t === "integer") {
      const m = numberProblem(v, p, t === "integer");
      if (m) out.push({ field: path, message: m });
    } else if (t === "array" && Array.isArray(v) && p.items) {
      const it = unwrapNullable(p.items, root).schema;
      const itType = primaryType(it);
      if (itType === "number" || itType === "integer")
        v.forEach((x, i) => {
          const m = numberProblem(x, it, itType === "integer");
          if (m) out.push({ field: `${path}.${i}`, message: m });
        });
    }
  }
  return out;
}

/** A comma-separated list of numbers as typed ("" -> null: the default). An item that is no number ("abc", "0x10") stays as its text, and the form names it. */
export function parseNumberList(text: string): (number | string)[] | null {
  const parts = text.split(",").map((x) => x.trim()).filter(Boolean);
  return parts.length ? parts.map((x) => readNumber(x) ?? x) : null;
}

interface FieldProps {
  name: string;
  path: string;
  schema: JsonSchema;
  root: JsonSchema;
  value: unknown;
  onChange: (v: unknown) => void;
  errors: ErrorView;
  required: boolean;
}

/** The messages of one field: one element per problem it owns. */
export function FieldMessages({ problems, id, item }: { problems: Problem[]; id?: string; item?: string }) {
  if (!problems.length) return null;
  return (
    <>
      {problems.map((p, i) => (
        <small key={p.path} id={i === 0 ? id : undefined} className="field-error" role="alert" data-error-path={p.path} title={`${p.label}: ${p.message}`}>
          {atFieldText(p, item)}
        </small>
      ))}
    </>
  );
}

function Field({ name, path, schema, root, value, onChange, errors, required }: FieldProps) {
  const id = useId();
  const { schema: s, nullable } = unwrapNullable(schema, root);
  const type = primaryType(s);
  const label = name;
  const problems = errors.at(path);
  const error = problems.length > 0;
  const hint = [s.description, bounds(s)].filter(Boolean).join(" · ");
  const describedBy = [hint ? `${id}-hint` : "", error ? `${id}-err` : ""].filter(Boolean).join(" ") || undefined;

  if (type === "object" && s.properties) {
    const obj = (value as Values | undefined) ?? {};
    return (
      <fieldset className="schema-group">
        <legend>{label}</legend>
        {s.description && <p className="hint">{s.description}</p>}
        {Object.entries(s.properties).map(([k, sub]) => (
          <Field
            key={k}
            name={k}
            path={`${path}.${k}`}
            schema={sub}
            root={root}
            value={obj[k]}
            onChange={(v) => onChange({ ...obj, [k]: v })}
            errors={errors}
            required={s.required?.includes(k) ?? false}
          />
        ))}
      </fieldset>
    );
  }

  let input;
  if (type === "boolean") {
    input = <input id={id} type="checkbox" checked={Boolean(value)} onChange={(e) => onChange(e.target.checked)} aria-describedby={describedBy} />;
  } else if (type === "enum" || type === "const") {
    const options = s.enum ?? [s.const];
    input = (
      <select id={id} value={value === undefined || value === null ? "" : String(value)} onChange={(e) => onChange(e.target.value === "" ? null : options.find((o) => String(o) === e.target.value))} aria-describedby={describedBy} aria-invalid={Boolean(error)}>
        {(nullable || value === undefined) && <option value="">—</option>}
        {options.map((o) => (
          <option key={String(o)} value={String(o)}>
            {String(o)}
          </option>
        ))}
      </select>
    );
  } else if (type === "number" || type === "integer") {
    input = (
      <NumberInput
        id={id}
        value={value}
        onChange={(v) => onChange(v === undefined ? (nullable ? null : undefined) : v)}
        required={required && !nullable}
        aria-describedby={describedBy}
        aria-invalid={Boolean(error)}
      />
    );
  } else if (type === "array") {
    const text = Array.isArray(value) ? value.join(", ") : "";
    const itemType = s.items ? primaryType(resolveRef(s.items, root)) : "string";
    input = (
      <input
        id={id}
        type="text"
        defaultValue={text}
        placeholder="comma-separated"
        onBlur={(e) => {
          const parts = e.target.value.split(",").map((x) => x.trim()).filter(Boolean);
          onChange(itemType === "number" || itemType === "integer" ? (parseNumberList(e.target.value) ?? (nullable ? null : [])) : parts);
        }}
        aria-describedby={describedBy}
        aria-invalid={Boolean(error)}
      />
    );
  } else if (type === "string") {
    input = (
      <input id={id} type="text" value={value === undefined || value === null ? "" : String(value)} onChange={(e) => onChange(e.target.value === "" && nullable ? null : e.target.value)} required={required && !nullable} aria-describedby={describedBy} aria-invalid={Boolean(error)} />
    );
  } else {
    input = (
      <textarea
        id={id}
        rows={3}
        defaultValue={value === undefined ? "" : JSON.stringify(value, null, 1)}
        onBlur={(e) => {
          try {
            onChange(e.target.value.trim() === "" ? undefined : JSON.parse(e.target.value));
          } catch {
            /* keep the last valid value; the API reports the error */
          }
        }}
        aria-describedby={describedBy}
      />
    );
  }

  return (
    <div className={`field${type === "boolean" ? " field-inline" : ""}`}>
      <label htmlFor={id}>
        {label}
        {required && !nullable && <span aria-hidden="true"> *</span>}
      </label>
      {input}
      {hint && (
        <small id={`${id}-hint`} className="hint">
          {hint}
        </small>
      )}
      <FieldMessages problems={problems} id={`${id}-err`} />
    </div>
  );
}

export interface SchemaFormProps {
  schema: JsonSchema;
  value: Values;
  onChange: (v: Values) => void;
  /** the form's problems; this form's fields are at `prefix` + their dotted path */
  errors?: ErrorView;
  prefix?: string;
  /** top-level fields another part of the page edits (not shown here) */
  omit?: readonly string[];
}

export function SchemaForm({ schema, value, onChange, errors = noErrors, prefix = "", omit = [] }: SchemaFormProps) {
  const root = resolveRef(schema, schema);
  const props = Object.fromEntries(Object.entries(root.properties ?? {}).filter(([k]) => !omit.includes(k)));
  if (Object.keys(props).length === 0) return <p className="muted">This type has no parameters.</p>;
  return (
    <div className="schema-form">
      {Object.entries(props).map(([k, sub]) => (
        <Field key={k} name={k} path={prefix ? `${prefix}.${k}` : k} schema={sub} root={schema} value={value[k]} onChange={(v) => onChange({ ...value, [k]: v })} errors={errors} required={root.required?.includes(k) ?? false} />
      ))}
    </div>
  );
}
