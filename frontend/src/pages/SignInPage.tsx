import { useState, type FormEvent } from "react";
import { useNavigate, useSearchParams } from "react-router-dom";
import { useAuth } from "../api/auth";
import { login } from "../api/users";
import { errorMessage } from "../api/errors";
import { useTitle } from "../lib/title";

export function SignInPage() {
  useTitle("Sign in");
  const { signIn } = useAuth();
  const navigate = useNavigate();
  const [params] = useSearchParams();
  const [username, setUsername] = useState("");
  const [password, setPassword] = useState("");
  const [error, setError] = useState<string | null>(null);
  const [busy, setBusy] = useState(false);

  async function submit(e: FormEvent) {
    e.preventDefault();
    setBusy(true);
    setError(null);
    try {
      const token = await login(username, password);
      signIn(token);
      const next = params.get("next");
      navigate(next && next.startsWith("/") && !next.startsWith("/signin") ? next : "/campaigns", { replace: true });
    } catch (err) {
      setError(errorMessage(err));
    } finally {
      setBusy(false);
    }
  }

  return (
    <main>
      <form className="panel signin" onSubmit={submit} aria-labelledby="signin-title">
        <h1 id="signin-title">Sign in to alcove</h1>
        <div className="field">
          <label htmlFor="username">Email</label>
          <input id="username" autoComplete="username" type="email" value={username} onChange={(e) => setUsername(e.target.value)} required autoFocus />
        </div>
        <div className="field">
          <label htmlFor="password">Password</label>
          <input id="password" type="password" autoComplete="current-password" value={password} onChange={(e) => setPassword(e.target.value)} required />
        </div>
        {error && (
          <p className="error-text" role="alert">
            {error}
          </p>
        )}
        <button className="primary" type="submit" disabled={busy}>
          {busy ? "Signing in…" : "Sign in"}
        </button>
      </form>
    </main>
  );
}
