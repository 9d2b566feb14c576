import { useState, type FormEvent } from "react";
import { useCreateToken, useRevokeToken, useTokens } from "../api/users";
import { Empty, ErrorBox, Loading } from "../components/States";
import { fmtDate } from "../lib/format";
import { FieldMessages } from "../components/SchemaForm";
import { generalFailure, serverProblems } from "../components/FormErrors";
import { cleanName, errorView, nameProblems } from "../lib/formErrors";
import { useTitle } from "../lib/title";

export function TokensPage() {
  useTitle("API tokens");
  const tokens = useTokens();
  const create = useCreateToken();
  const revoke = useRevokeToken();
  const [name, setName] = useState("");
  const [secret, setSecret] = useState<string | null>(null);
  const [copied, setCopied] = useState(false);
  const [submitted, setSubmitted] = useState(false);
  // the form's own check once it was submitted, then the server's answer (a refused name is named at the field)
  const view = errorView([submitted ? nameProblems(name) : [], serverProblems(create.error)], ["name"], () => "Name");

  function submit(e: FormEvent) {
    e.preventDefault();
    setSubmitted(true);
    if (nameProblems(name).length) return;
    create.mutate(
      { name: cleanName(name) },
      {
        onSuccess: (created) => {
          setSecret(created.token);
          setCopied(false);
          setName("");
          setSubmitted(false);
        },
      },
    );
  }

  return (
    <>
      <h1>API tokens</h1>
      <p className="muted">Personal tokens let scripts and notebooks call the API as you. A token is shown once, when it is created.</p>
      <form className="panel toolbar" onSubmit={submit}>
        <label htmlFor="token-name">Name</label>
        <input
          id="token-name"
          value={name}
          onChange={(e) => {
            setName(e.target.value);
            if (create.isError) create.reset();
          }}
          placeholder="e.g. notebook"
          required
          maxLength={200}
          aria-invalid={view.at("name").length > 0}
          aria-describedby={view.at("name").length ? "token-name-err" : undefined}
        />
        <button className="primary" type="submit" disabled={create.isPending}>
          Create token
        </button>
        <FieldMessages problems={view.problems} id="token-name-err" />
        {generalFailure(create.error) && <span className="error-text">{generalFailure(create.error)}</span>}
      </form>
      {secret && (
        <div className="panel" role="status">
          <p>
            <strong>Copy this token now.</strong> It will not be shown again.
          </p>
          <div className="token-once" data-testid="new-token">
            {secret}
          </div>
          <div className="toolbar" style={{ marginTop: 8 }}>
            <button
              type="button"
              onClick={() => {
                void navigator.clipboard?.writeText(secret).then(() => setCopied(true));
              }}
            >
              {copied ? "Copied" : "Copy"}
            </button>
            <button type="button" onClick={() => setSecret(null)}>
              Done
            </button>
          </div>
        </div>
      )}
      <section className="panel">
        {tokens.isPending ? (
          <Loading />
        ) : tokens.isError ? (
          <ErrorBox error={tokens.error} retry={() => void tokens.refetch()} />
        ) : tokens.data.length === 0 ? (
          <Empty title="No API tokens yet">Create one above to use the API from a script.</Empty>
        ) : (
          <table>
            <thead>
              <tr>
                <th>Name</th>
                <th>Created</th>
                <th>Last used</th>
                <th>Expires</th>
                <th>
                  <span className="sr-only">Actions</span>
                </th>
              </tr>
            </thead>
            <tbody>
              {tokens.data.map((t) => (
                <tr key={t.id}>
                  <td>{t.name}</td>
                  <td>{fmtDate(t.created_at)}</td>
                  <td>{fmtDate(t.last_used_at)}</td>
                  <td>{t.expires_at ? fmtDate(t.expires_at) : "never"}</td>
                  <td>
                    {t.revoked ? (
                      <span className="muted">revoked</span>
                    ) : (
                      <button
                        type="button"
                        className="danger"
                        onClick={() => {
                          if (confirm(`Revoke token "${t.name}"? Scripts using it will stop working.`)) revoke.mutate(t.id);
                        }}
                      >
                        Revoke
                      </button>
                    )}
                  </td>
                </tr>
              ))}
            </tbody>
          </table>
        )}
      </section>
    </>
  );
}
