import { Link } from "react-router-dom";
import { useTasks } from "../api/hooks";
import { Empty, ErrorBox, Loading } from "../components/States";
import { fmtDate } from "../lib/format";

export function TasksPage() {
  const tasks = useTasks();
  return (
    <>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>Tasks</h1>
        <span className="spacer" />
        <Link className="button primary" to="/tasks/new">
          New task
        </Link>
      </div>
      <div className="panel">
        {tasks.isPending ? (
          <Loading />
        ) : tasks.isError ? (
          <ErrorBox error={tasks.error} retry={() => void tasks.refetch()} />
        ) : tasks.data.length === 0 ? (
          <Empty title="No tasks yet">
            A task is the optimal-control problem a campaign solves. <Link to="/tasks/new">Create one from a preset.</Link>
          </Empty>
        ) : (
          <table>
            <thead>
              <tr>
                <th>Name</th>
                <th className="num">Version</th>
                <th className="num">Phases</th>
                <th>Owner</th>
                <th>Updated</th>
              </tr>
            </thead>
            <tbody>
              {tasks.data.map((t) => (
                <tr key={t.id}>
                  <td>
                    <Link to={`/tasks/${t.id}`}>{t.name}</Link>
                  </td>
                  <td className="num">{t.version ?? "—"}</td>
                  <td className="num">{t.n_phases ?? "—"}</td>
                  <td>{t.owner ?? "—"}</td>
                  <td>{fmtDate(t.updated_at)}</td>
                </tr>
              ))}
            </tbody>
          </table>
        )}
      </div>
    </>
  );
}
