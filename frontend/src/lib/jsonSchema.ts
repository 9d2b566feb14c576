/**
 * JSON Schema as pydantic emits it (the subset the forms read), and the two lookups every
 * schema reader needs: following a `$ref` into `$defs`, and the non-null branch of a
 * nullable field. No React: the form (components/SchemaForm) and the error placement
 * (lib/formErrors) both build on it.
 */

export interface JsonSchema {
  type?: string | string[];
  title?: string;
  description?: string;
  default?: unknown;
  enum?: unknown[];
  const?: unknown;
  minimum?: number;
  maximum?: number;
  exclusiveMinimum?: number;
  exclusiveMaximum?: number;
  properties?: Record<string, JsonSchema>;
  required?: string[];
  items?: JsonSchema;
  anyOf?: JsonSchema[];
  oneOf?: JsonSchema[];
  allOf?: JsonSchema[];
  $ref?: string;
  $defs?: Record<string, JsonSchema>;
  definitions?: Record<string, JsonSchema>;
  [key: string]: unknown;
}

export function resolveRef(schema: JsonSchema, root: JsonSchema): JsonSchema {
  let s = schema;
  for (let guard = 0; s.$ref && guard < 16; guard++) {
    const name = s.$ref.split("/").pop() ?? "";
    const target = root.$defs?.[name] ?? root.definitions?.[name];
    if (!target) break;
    const { $ref: _ignored, ...rest } = s;
    s = { ...target, ...rest };
  }
  if (s.allOf?.length === 1) s = { ...resolveRef(s.allOf[0], root), ...s, allOf: undefined };
  return s;
}

/** The non-null branch of `anyOf: [X, {type: null}]`, and whether null is allowed. */
export function unwrapNullable(schema: JsonSchema, root: JsonSchema): { schema: JsonSchema; nullable: boolean } {
  const s = resolveRef(schema, root);
  const alts = s.anyOf ?? s.oneOf;
  if (alts) {
    const nonNull = alts.filter((a) => a.type !== "null");
    const nullable = nonNull.length < alts.length;
    if (nonNull.length === 1) {
      const { anyOf: _a, oneOf: _o, ...rest } = s;
      return { schema: { ...resolveRef(nonNull[0], root), ...rest }, nullable };
    }
    return { schema: s, nullable };
  }
  return { schema: s, nullable: Array.isArray(s.type) && s.type.includes("null") };
}
