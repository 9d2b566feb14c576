import { Link } from "react-router-dom";
import { useOracles } from "../api/hooks";
import { Empty, ErrorBox, Loading } from "../components/States";
import { fmtDate } from "../lib/format";

export function OraclesPage() {
  const oracles = useOracles();
  return (
    <>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>Oracles</h1>
        <span className="spacer" />
        <Link className="button primary" to="/oracles/new">
          New oracle
        </Link>
      </div>
      <div className="panel">
        {oracles.isPending ? (
          <Loading />
        ) : oracles.isError ? (
          <ErrorBox error={oracles.error} retry={() => void oracles.refetch()} />
        ) : oracles.data.length === 0 ? (
          <Empty title="No oracles yet">
            An oracle computes the true contact forces for a trajectory. <Link to="/oracles/new">Create one.</Link>
          </Empty>
        ) : (
          <table>
            <thead>
              <tr>
                <th>Name</th>
                <th>Type</th>
                <th className="num">Version</th>
                <th>Owner</th>
                <th>Updated</th>
              </tr>
            </thead>
            <tbody>
              {oracles.data.map((o) => (
                <tr key={o.id}>
                  <td>
                    <Link to={`/oracles/${o.id}`}>{o.name}</Link>
                  </td>
                  <td>{o.type}</td>
                  <td className="num">{o.version ?? "—"}</td>
                  <td>{o.owner ?? "—"}</td>
                  <td>{fmtDate(o.updated_at)}</td>
                </tr>
              ))}
            </tbody>
          </table>
        )}
      </div>
    </>
  );
}
