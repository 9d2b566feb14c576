/** The editable settings of a campaign (new campaign, fork), each a form generated from the API's own schema. */
import { componentSchema, useOpenApi, type OpenApiDocument } from "../api/definitions";
import type { FieldError } from "../api/errors";
import { ErrorBox, Loading } from "../components/States";
import { FieldMessages, SchemaForm, schemaDefaults, schemaFieldPaths, schemaLocalErrors } from "../components/SchemaForm";
import { noErrors, schemaLabel, type ErrorView } from "../lib/formErrors";

/** Editable campaign settings, each a form generated from the API's own schema. */
const SECTIONS = [
  ["preliminary", "PreliminaryConfig", "Preliminary data (pool version 0)"],
  ["stopping", "StoppingRules", "Stopping rules"],
  ["settings", "RunSettings", "Run settings"],
  ["policies", "Policies", "Failure policies"],
] as const;

export type ConfigDraft = Record<string, Record<string, unknown>>;

export type ConfigKey = (typeof SECTIONS)[number][0];

function sections(only?: readonly string[]) {
  return SECTIONS.filter(([key]) => !only || only.includes(key));
}

/** The field paths the config sections show ("stopping.max_iterations", ...), and each section's own ("stopping": a rule across its fields), for placing errors. */
export function configFieldPaths(doc: OpenApiDocument | undefined, only?: readonly string[]): string[] {
  return sections(only).flatMap(([key, name]) => {
    const schema = componentSchema(doc, name);
    return schema ? [key, ...schemaFieldPaths(schema, schema, key)] : [];
  });
}

/** The form's own checks of the config (numbers, whole numbers, the schemas' bounds). */
export function configLocalErrors(doc: OpenApiDocument | undefined, value: ConfigDraft, only?: readonly string[]): FieldError[] {
  return sections(only).flatMap(([key, name]) => {
    const schema = componentSchema(doc, name);
    return schema ? schemaLocalErrors(schema, value[key], schema, key) : [];
  });
}

/** The label of a config path, from the schemas' titles and descriptions. */
export function configLabel(doc: OpenApiDocument | undefined, path: string): string {
  const [key, ...rest] = path.split(".");
  const section = SECTIONS.find(([k]) => k === key);
  const schema = section ? componentSchema(doc, section[1]) : null;
  if (!schema) return path;
  return rest.length ? `${section![2]} › ${schemaLabel(schema, rest.join("."))}` : section![2];
}

export function ConfigSections({
  value,
  onChange,
  errors = noErrors,
  only,
  omit = [],
}: {
  value: ConfigDraft;
  onChange: (v: ConfigDraft) => void;
  errors?: ErrorView;
  only?: readonly string[];
  /** dotted paths ("settings.batch") another section of the page edits */
  omit?: readonly string[];
}) {
  const openapi = useOpenApi();
  if (openapi.isPending) return <Loading label="Loading settings form…" />;
  if (openapi.isError) return <ErrorBox error={openapi.error} />;
  return (
    <>
      {sections(only).map(([key, schemaName, title]) => {
        const schema = componentSchema(openapi.data, schemaName);
        if (!schema) return null;
        const hidden = omit.filter((p) => p.startsWith(`${key}.`)).map((p) => p.slice(key.length + 1));
        const body = (
          <>
            <FieldMessages problems={errors.at(key)} />
            <SchemaForm schema={schema} value={value[key] ?? {}} onChange={(v) => onChange({ ...value, [key]: v })} errors={errors} prefix={key} omit={hidden} />
          </>
        );
        return key === "policies" ? (
          <details key={key} className="panel" open={errors.problems.some((p) => p.field === key || p.field?.startsWith(`${key}.`))}>
            <summary>{title}</summary>
            {body}
          </details>
        ) : (
          <section key={key} className="panel" aria-label={title}>
            <h2>{title}</h2>
            {body}
          </section>
        );
      })}
    </>
  );
}

export function useConfigDefaults(): ConfigDraft | null {
  const openapi = useOpenApi();
  if (!openapi.data) return null;
  const out: ConfigDraft = {};
  for (const [key, schemaName] of SECTIONS) {
    const schema = componentSchema(openapi.data, schemaName);
    if (schema) out[key] = schemaDefaults(schema);
  }
  return out;
}

