/**
 * The editor shell shared by the task and oracle editors: name and description, the count of
 * problems, save (a definition a campaign used is saved as a new version), the problems no
 * field shows, the version history and the shares. The kind-specific sections are its children.
 */
import { useState, type FormEvent, type ReactNode } from "react";
import { useShare, useShares, useVersions, type DefinitionKind } from "../api/definitions";
import { errorMessage } from "../api/errors";
import { fmtDate } from "../lib/format";
import type { ErrorView } from "../lib/formErrors";
import { ErrorCount, FormErrors } from "./FormErrors";
import { FieldMessages } from "./SchemaForm";
import { useTitle } from "../lib/title";

export interface Saved {
  id: number;
  version: number;
  version_locked: boolean;
  can_edit: boolean;
}

export function DefinitionEditor({
  kind,
  noun,
  existing,
  name,
  setName,
  description,
  setDescription,
  errors,
  checking = false,
  failure,
  saving,
  onSave,
  actions,
  children,
}: {
  kind: DefinitionKind;
  noun: string;
  existing: Saved | undefined;
  name: string;
  setName: (v: string) => void;
  description: string;
  setDescription: (v: string) => void;
  errors: ErrorView;
  checking?: boolean;
  /** the failure of the last save or preview, shown once (field problems are in `errors`) */
  failure?: unknown;
  saving: boolean;
  onSave: () => void;
  /** extra toolbar controls (preset, previews) */
  actions?: ReactNode;
  children: ReactNode;
}) {
  const heading = existing ? `${noun[0].toUpperCase()}${noun.slice(1)}: ${name}` : `New ${noun}`;
  useTitle(heading);
  const submit = (e: FormEvent) => {
    e.preventDefault();
    onSave();
  };
  const saveLabel = !existing ? `Create ${noun}` : existing.version_locked ? `Save as version ${existing.version + 1}` : "Save";
  return (
    <form onSubmit={submit} noValidate>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>{heading}</h1>
        {existing && <span className="badge">version {existing.version}</span>}
        <ErrorCount view={errors} checking={checking} />
        <span className="spacer" />
        {actions}
        <button
          type="submit"
          className="primary"
          disabled={saving || (existing ? !existing.can_edit : false)}
          title={existing?.version_locked ? `Version ${existing.version} is used by a campaign; saving keeps it and makes version ${existing.version + 1}` : undefined}
        >
          {saveLabel}
        </button>
      </div>
      <FormErrors view={errors} failure={failure} />
      <section className="panel">
        <div className="row">
          <div className="field grow">
            <label htmlFor={`${kind}-name`}>Name</label>
            <input id={`${kind}-name`} value={name} onChange={(e) => setName(e.target.value)} required maxLength={200} aria-invalid={errors.at("name").length > 0} />
            <FieldMessages problems={errors.at("name")} />
          </div>
          <div className="field grow">
            <label htmlFor={`${kind}-description`}>Description</label>
            <input id={`${kind}-description`} value={description} onChange={(e) => setDescription(e.target.value)} aria-invalid={errors.at("description").length > 0} />
            <FieldMessages problems={errors.at("description")} />
          </div>
        </div>
      </section>
      {children}
      {existing && (
        <div className="grid2">
          <VersionHistory kind={kind} id={existing.id} />
          <Shares kind={kind} id={existing.id} canEdit={existing.can_edit} />
        </div>
      )}
    </form>
  );
}

function VersionHistory({ kind, id }: { kind: DefinitionKind; id: number }) {
  const versions = useVersions(kind, id);
  return (
    <section className="panel" aria-labelledby={`${kind}-versions`}>
      <h2 id={`${kind}-versions`}>Version history</h2>
      {versions.isError ? (
        <p className="error-text">{errorMessage(versions.error)}</p>
      ) : !versions.data ? (
        <p className="muted">Loading…</p>
      ) : (
        <table data-testid="version-history">
          <thead>
            <tr>
              <th className="num">Version</th>
              <th>Created</th>
              <th>Used by a campaign</th>
              <th>Note</th>
            </tr>
          </thead>
          <tbody>
            {versions.data.map((v) => (
              <tr key={v.version}>
                <td className="num">{v.version}</td>
                <td>{fmtDate(v.created_at)}</td>
                <td>{v.locked ? "yes (kept as it is)" : "no"}</td>
                <td>{v.note || "—"}</td>
              </tr>
            ))}
          </tbody>
        </table>
      )}
    </section>
  );
}

function Shares({ kind, id, canEdit }: { kind: DefinitionKind; id: number; canEdit: boolean }) {
  const shares = useShares(kind, id);
  const { add, remove } = useShare(kind, id);
  const [email, setEmail] = useState("");
  const [permission, setPermission] = useState<"view" | "edit">("view");
  const [sharedWith, setSharedWith] = useState<string | null>(null);
  const share = () =>
    add.mutate(
      { email, permission },
      {
        onSuccess: (s) => {
          setSharedWith(s.email);
          setEmail("");
        },
      },
    );
  return (
    <section className="panel" aria-labelledby={`${kind}-shares`}>
      <h2 id={`${kind}-shares`}>Shared with</h2>
      {shares.data?.length ? (
        <ul>
          {shares.data.map((s) => (
            <li key={s.id}>
              {s.email} ({s.permission}){" "}
              {canEdit && (
                <button type="button" className="link" onClick={() => remove.mutate(s.id)}>
                  stop sharing
                </button>
              )}
            </li>
          ))}
        </ul>
      ) : (
        <p className="muted">{shares.isError ? errorMessage(shares.error) : "Only you (and admins) can see it."}</p>
      )}
      {canEdit && (
        <div className="toolbar">
          <label htmlFor={`${kind}-share-email`}>Share with</label>
          <input id={`${kind}-share-email`} type="email" value={email} placeholder="e-mail" onChange={(e) => setEmail(e.target.value)} />
          <select aria-label="Permission" value={permission} onChange={(e) => setPermission(e.target.value as "view" | "edit")}>
            <option value="view">can view</option>
            <option value="edit">can edit</option>
          </select>
          <button type="button" disabled={!email || add.isPending} onClick={share}>
            Share
          </button>
          {add.isError && <span className="error-text">{errorMessage(add.error)}</span>}
          {sharedWith && !add.isError && (
            <span className="muted" role="status">
              Shared with {sharedWith}. If no account uses this address yet, the account made with it will get it.
            </span>
          )}
        </div>
      )}
    </section>
  );
}
