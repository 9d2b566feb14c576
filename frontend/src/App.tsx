import { lazy, Suspense, useEffect, useRef, useState } from "react";
import { Link, Navigate, NavLink, Route, Routes, useLocation } from "react-router-dom";
import { useAuth } from "./api/auth";
import { useMe, userLabel } from "./api/users";
import { Loading } from "./components/States";
import { SignInPage } from "./pages/SignInPage";
import { CampaignsPage } from "./pages/CampaignsPage";
import { CampaignPage } from "./pages/CampaignPage";
import { useTitle } from "./lib/title";

const TasksPage = lazy(() => import("./pages/TasksPage").then((m) => ({ default: m.TasksPage })));
const TaskEditorPage = lazy(() => import("./pages/TaskEditorPage").then((m) => ({ default: m.TaskEditorPage })));
const OraclesPage = lazy(() => import("./pages/OraclesPage").then((m) => ({ default: m.OraclesPage })));
const OracleEditorPage = lazy(() => import("./pages/OracleEditorPage").then((m) => ({ default: m.OracleEditorPage })));
const NewCampaignPage = lazy(() => import("./pages/NewCampaignPage").then((m) => ({ default: m.NewCampaignPage })));
const ComparePage = lazy(() => import("./pages/ComparePage").then((m) => ({ default: m.ComparePage })));
const TokensPage = lazy(() => import("./pages/TokensPage").then((m) => ({ default: m.TokensPage })));

function UserMenu() {
  const { signOut } = useAuth();
  const me = useMe();
  const [open, setOpen] = useState(false);
  const ref = useRef<HTMLDivElement>(null);
  useEffect(() => {
    if (!open) return;
    const close = (e: MouseEvent | KeyboardEvent) => {
      if (e instanceof KeyboardEvent ? e.key === "Escape" : !ref.current?.contains(e.target as Node)) setOpen(false);
    };
    document.addEventListener("mousedown", close);
    document.addEventListener("keydown", close);
    return () => {
      document.removeEventListener("mousedown", close);
      document.removeEventListener("keydown", close);
    };
  }, [open]);
  return (
    <div className="user-menu" ref={ref}>
      <button type="button" aria-haspopup="menu" aria-expanded={open} onClick={() => setOpen((o) => !o)}>
        {me.data ? `${userLabel(me.data)} (${me.data.role})` : "Account"} ▾
      </button>
      {open && (
        <div className="menu" role="menu">
          <Link role="menuitem" to="/tokens" onClick={() => setOpen(false)}>
            API tokens
          </Link>
          <button role="menuitem" type="button" onClick={signOut}>
            Sign out
          </button>
        </div>
      )}
    </div>
  );
}

function NotFound() {
  useTitle("Page not found");
  return (
    <p>
      Page not found. <Link to="/campaigns">Back to campaigns</Link>
    </p>
  );
}

function Shell() {
  return (
    <>
      <header className="app-header">
        <Link to="/campaigns" className="brand">
          alcove
        </Link>
        <nav aria-label="Main" style={{ display: "flex", gap: 16 }}>
          <NavLink to="/campaigns">Campaigns</NavLink>
          <NavLink to="/compare">Compare</NavLink>
          <NavLink to="/tasks">Tasks</NavLink>
          <NavLink to="/oracles">Oracles</NavLink>
        </nav>
        <span className="spacer" />
        <UserMenu />
      </header>
      <main>
        <Suspense fallback={<Loading />}>
          <Routes>
            <Route path="/" element={<Navigate to="/campaigns" replace />} />
            <Route path="/campaigns" element={<CampaignsPage />} />
            <Route path="/campaigns/new" element={<NewCampaignPage />} />
            <Route path="/campaigns/:id" element={<CampaignPage />} />
            <Route path="/compare" element={<ComparePage />} />
            <Route path="/tasks" element={<TasksPage />} />
            <Route path="/tasks/new" element={<TaskEditorPage />} />
            <Route path="/tasks/:id" element={<TaskEditorPage />} />
            <Route path="/oracles" element={<OraclesPage />} />
            <Route path="/oracles/new" element={<OracleEditorPage />} />
            <Route path="/oracles/:id" element={<OracleEditorPage />} />
            <Route path="/tokens" element={<TokensPage />} />
            <Route path="*" element={<NotFound />} />
          </Routes>
        </Suspense>
      </main>
    </>
  );
}

export function App() {
  const { token } = useAuth();
  const location = useLocation();
  if (!token) {
    if (location.pathname === "/signin") return <SignInPage />;
    return <Navigate to={`/signin?next=${encodeURIComponent(location.pathname + location.search)}`} replace />;
  }
  if (location.pathname === "/signin") return <Navigate to="/campaigns" replace />;
  return <Shell />;
}
