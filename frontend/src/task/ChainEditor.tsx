/**
 * A chain model (model.chain) as tables: its links (mass, COG, inertia, length) and joints
 * (range, initial angle, torque limit, spring, damper), each cell with its unit and the range
 * the API accepts (from the task's JSON Schema); the rest of the chain (gravity, base, contact
 * body and profile, headrest) as a generated form. Problems show at their cell, by the API's
 * paths (`model.chain.joints.1.q0`).
 */
import type { FieldError } from "../api/errors";
import { FieldMessages, numberProblem, resolveRef, SchemaForm, schemaFieldPaths, schemaLocalErrors, type JsonSchema } from "../components/SchemaForm";
import type { ErrorView } from "../lib/formErrors";
import { NumberInput } from "../components/NumberInput";

type Json = Record<string, unknown>;
export const MAX_LINKS = 6;
const PREFIX = "model.chain";

interface Column {
  /** the field (a COG coordinate is com.0 / com.1) */
  key: string;
  header: string;
  unit: string;
}

const LINK_COLUMNS: Column[] = [
  { key: "mass", header: "mass", unit: "kg" },
  { key: "com.0", header: "COG x", unit: "m" },
  { key: "com.1", header: "COG z", unit: "m" },
  { key: "inertia_com", header: "inertia about COG", unit: "kg m²" },
  { key: "length", header: "length", unit: "m" },
];
const JOINT_COLUMNS: Column[] = [
  { key: "q_min", header: "q min", unit: "rad" },
  { key: "q_max", header: "q max", unit: "rad" },
  { key: "q0", header: "q0 (start)", unit: "rad" },
  { key: "torque_limit", header: "torque limit", unit: "N m" },
  { key: "stiffness", header: "stiffness", unit: "N m/rad" },
  { key: "q_rest", header: "spring rest", unit: "rad" },
  { key: "damping", header: "damping", unit: "N m s/rad" },
];

function get(row: Json, key: string): unknown {
  const [a, b] = key.split(".");
  const v = row[a];
  return b === undefined ? v : Array.isArray(v) ? v[Number(b)] : undefined;
}

function set(row: Json, key: string, value: unknown): Json {
  const [a, b] = key.split(".");
  if (b === undefined) return { ...row, [a]: value };
  const arr = Array.isArray(row[a]) ? [...(row[a] as unknown[])] : [undefined, undefined];
  arr[Number(b)] = value;
  return { ...row, [a]: arr };
}

/** The schema of a cell: a property of LinkSpec / JointSpec (a COG coordinate: the tuple's item). */
function cellSchema(root: JsonSchema | undefined, def: "LinkSpec" | "JointSpec", key: string): JsonSchema {
  const spec = root?.$defs?.[def];
  const [a, b] = key.split(".");
  const prop = spec?.properties?.[a];
  if (!prop || !root) return {};
  const s = resolveRef(prop, root);
  if (b !== undefined) {
    const items = (s.prefixItems as JsonSchema[] | undefined)?.[Number(b)] ?? s.items;
    return items ? resolveRef(items, root) : {};
  }
  return s;
}

/** "0 to 200" from a schema's bounds (> for exclusive ones). */
export function rangeText(s: JsonSchema): string {
  // 4 significant digits: ±π/2 reads -1.571 to 1.571, not 16 digits
  const short = (x: number) => String(Number(x.toPrecision(4)));
  const lo = s.minimum !== undefined ? short(s.minimum) : s.exclusiveMinimum !== undefined ? `> ${short(s.exclusiveMinimum)}` : null;
  const hi = s.maximum !== undefined ? short(s.maximum) : s.exclusiveMaximum !== undefined ? `< ${short(s.exclusiveMaximum)}` : null;
  if (lo !== null && hi !== null) return lo.startsWith(">") ? `${lo}, ≤ ${hi}` : `${lo} to ${hi}`;
  return lo ?? (hi !== null ? `≤ ${hi}` : "");
}

/** The chain's schema without the links and joints (the tables show them). */
export function restSchema(root: JsonSchema | undefined): JsonSchema | null {
  const chain = root?.$defs?.ChainSpec;
  if (!chain?.properties) return null;
  const properties = { ...chain.properties };
  delete properties.links;
  delete properties.joints;
  return { ...chain, properties, required: (chain.required ?? []).filter((k) => k !== "links" && k !== "joints") };
}

/** The paths of the editor's fields (cells and the rest's fields), for placing problems. */
export function chainFieldPaths(chain: Json | undefined, root: JsonSchema | undefined): string[] {
  const links = Array.isArray(chain?.links) ? (chain.links as Json[]) : [];
  const out = [`${PREFIX}`, `${PREFIX}.links`, `${PREFIX}.joints`];
  links.forEach((_, i) => {
    out.push(`${PREFIX}.links.${i}.name`, `${PREFIX}.joints.${i}.name`);
    for (const c of LINK_COLUMNS) out.push(`${PREFIX}.links.${i}.${c.key}`);
    for (const c of JOINT_COLUMNS) out.push(`${PREFIX}.joints.${i}.${c.key}`);
  });
  const rest = restSchema(root);
  if (rest && root) out.push(...schemaFieldPaths({ ...rest, $defs: root.$defs }, root, PREFIX));
  return out;
}

/** The editor's own checks: numbers and the schema's bounds of every cell and field. */
export function chainLocalErrors(chain: Json | undefined, root: JsonSchema | undefined): FieldError[] {
  if (!chain) return [];
  const out: FieldError[] = [];
  const rows = (k: string) => (Array.isArray(chain[k]) ? (chain[k] as Json[]) : []);
  rows("links").forEach((row, i) => {
    for (const c of LINK_COLUMNS) {
      const m = numberProblem(get(row, c.key), cellSchema(root, "LinkSpec", c.key), false);
      if (m) out.push({ field: `${PREFIX}.links.${i}.${c.key}`, message: m });
    }
  });
  rows("joints").forEach((row, i) => {
    for (const c of JOINT_COLUMNS) {
      const m = numberProblem(get(row, c.key), cellSchema(root, "JointSpec", c.key), false);
      if (m) out.push({ field: `${PREFIX}.joints.${i}.${c.key}`, message: m });
    }
  });
  const rest = restSchema(root);
  if (rest && root) out.push(...schemaLocalErrors({ ...rest, $defs: root.$defs }, chain, root, PREFIX));
  return out;
}

/** Insert a link and its joint before the last link (the head stays the end of the chain). */
export function addLink(chain: Json): Json {
  const links = [...((chain.links as Json[]) ?? [])];
  const joints = [...((chain.joints as Json[]) ?? [])];
  if (links.length >= MAX_LINKS) return chain;
  const at = Math.max(links.length - 1, 0);
  links.splice(at, 0, { name: `link ${at + 1}`, mass: 1.0, com: [0.0, 0.05], inertia_com: 0.001, length: 0.1 });
  joints.splice(at, 0, { name: `joint ${at + 1}`, q_min: -0.5, q_max: 0.5, q0: 0.0, torque_limit: 30.0, stiffness: 0.0, q_rest: 0.0, damping: 0.0 });
  return reindex({ ...chain, links, joints }, (i) => (i >= at ? i + 1 : i), (touch) => [...touch.slice(0, at), 0, ...touch.slice(at)]);
}

/** Remove link i and its joint (a chain keeps at least one link). */
export function removeLink(chain: Json, i: number): Json {
  const links = ((chain.links as Json[]) ?? []).filter((_, k) => k !== i);
  const joints = ((chain.joints as Json[]) ?? []).filter((_, k) => k !== i);
  if (!links.length) return chain;
  return reindex({ ...chain, links, joints }, (k) => (k === i ? null : k > i ? k - 1 : k), (touch) => touch.filter((_, k) => k !== i));
}

/** The contact body's link index and the headrest's touch pose follow an inserted or removed link. */
function reindex(chain: Json, link: (i: number) => number | null, touch: (q: unknown[]) => unknown[]): Json {
  const body = (chain.contact_body ?? {}) as Json;
  const hr = (chain.headrest ?? {}) as Json;
  const out = { ...chain };
  if (typeof body.link === "number") out.contact_body = { ...body, link: link(body.link) };
  if (Array.isArray(hr.touch_q)) out.headrest = { ...hr, touch_q: touch(hr.touch_q) };
  return out;
}

function Cell({ path, value, schema, unit, label, errors, onChange }: { path: string; value: unknown; schema: JsonSchema; unit: string; label: string; errors: ErrorView; onChange: (v: unknown) => void }) {
  const problems = errors.at(path);
  return (
    <td>
      <NumberInput
        aria-label={`${label} [${unit}]`}
        className="num-cell"
        value={value}
        onChange={onChange}
        aria-invalid={problems.length > 0}
        title={schema.description}
      />
      <FieldMessages problems={problems} />
    </td>
  );
}

function Table({
  kind,
  rows,
  columns,
  def,
  root,
  errors,
  onRow,
  onRemove,
}: {
  kind: "link" | "joint";
  rows: Json[];
  columns: Column[];
  def: "LinkSpec" | "JointSpec";
  root: JsonSchema | undefined;
  errors: ErrorView;
  onRow: (i: number, row: Json) => void;
  onRemove?: (i: number) => void;
}) {
  const plural = `${kind}s`;
  return (
    <table data-testid={`chain-${plural}`} className="chain-table">
      <thead>
        <tr>
          <th>#</th>
          <th>name</th>
          {columns.map((c) => (
            <th key={c.key} title={cellSchema(root, def, c.key).description}>
              {c.header} [{c.unit}]
              <small className="hint">{rangeText(cellSchema(root, def, c.key))}</small>
            </th>
          ))}
          {onRemove && (
            <th>
              <span className="sr-only">Actions</span>
            </th>
          )}
        </tr>
      </thead>
      <tbody>
        {rows.map((row, i) => (
          <tr key={i}>
            <td>{i + 1}</td>
            <td>
              <input aria-label={`${kind} ${i + 1} name`} value={String(row.name ?? "")} size={12} onChange={(e) => onRow(i, { ...row, name: e.target.value })} />
              <FieldMessages problems={errors.at(`${PREFIX}.${plural}.${i}.name`)} />
            </td>
            {columns.map((c) => (
              <Cell
                key={c.key}
                path={`${PREFIX}.${plural}.${i}.${c.key}`}
                value={get(row, c.key)}
                schema={cellSchema(root, def, c.key)}
                unit={c.unit}
                label={`${kind} ${i + 1} ${c.header}`}
                errors={errors}
                onChange={(v) => onRow(i, set(row, c.key, v))}
              />
            ))}
            {onRemove && (
              <td>
                <button type="button" className="link" disabled={rows.length <= 1} onClick={() => onRemove(i)} aria-label={`Remove link ${i + 1}`}>
                  remove
                </button>
              </td>
            )}
          </tr>
        ))}
      </tbody>
    </table>
  );
}

export function ChainEditor({ chain, onChange, root, errors }: { chain: Json; onChange: (c: Json) => void; root: JsonSchema | undefined; errors: ErrorView }) {
  const links = (Array.isArray(chain.links) ? chain.links : []) as Json[];
  const joints = (Array.isArray(chain.joints) ? chain.joints : []) as Json[];
  const rest = restSchema(root);
  const restValue = Object.fromEntries(Object.entries(chain).filter(([k]) => k !== "links" && k !== "joints"));
  return (
    <div data-testid="chain-editor">
      <h3 className="subhead">Links (from the base; joint i sits at the start of link i)</h3>
      <Table kind="link" rows={links} columns={LINK_COLUMNS} def="LinkSpec" root={root} errors={errors} onRow={(i, row) => onChange({ ...chain, links: links.map((l, k) => (k === i ? row : l)) })} onRemove={(i) => onChange(removeLink(chain, i))} />
      <FieldMessages problems={errors.at(`${PREFIX}.links`)} />
      <button type="button" disabled={links.length >= MAX_LINKS} onClick={() => onChange(addLink(chain))} title="A new link and its joint before the last link">
        Add link
      </button>
      <h3 className="subhead">Joints (angles relative to the previous link; positive: backward, toward the headrest)</h3>
      <Table kind="joint" rows={joints} columns={JOINT_COLUMNS} def="JointSpec" root={root} errors={errors} onRow={(i, row) => onChange({ ...chain, joints: joints.map((j, k) => (k === i ? row : j)) })} />
      <FieldMessages problems={errors.at(`${PREFIX}.joints`)} />
      <FieldMessages problems={errors.at(PREFIX)} />
      {rest && root && (
        // keyed by the link count: its list fields (headrest.touch_q) are typed text, re-read when a link is added or removed
        <SchemaForm key={links.length} schema={{ ...rest, $defs: root.$defs }} value={restValue} onChange={(v) => onChange({ ...v, links: chain.links, joints: chain.joints })} errors={errors} prefix={PREFIX} />
      )}
    </div>
  );
}
