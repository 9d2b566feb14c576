import { Link } from "react-router-dom";
import { useTasks } from "../api/definitions";
import { DefinitionListPage } from "../components/DefinitionList";

export function TasksPage() {
  return (
    <DefinitionListPage
      title="Tasks"
      path="/tasks"
      noun="task"
      query={useTasks()}
      columns={[{ header: "Phases", num: true, cell: (t) => t.n_phases }]}
      empty={
        <>
          A task is the optimal-control problem a campaign solves. <Link to="/tasks/new">Create one from a preset.</Link>
        </>
      }
    />
  );
}
