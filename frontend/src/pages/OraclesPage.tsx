import { Link } from "react-router-dom";
import { useOracles } from "../api/definitions";
import { DefinitionListPage } from "../components/DefinitionList";

export function OraclesPage() {
  return (
    <DefinitionListPage
      title="Oracles"
      path="/oracles"
      noun="oracle"
      query={useOracles()}
      columns={[{ header: "Type", cell: (o) => o.type }]}
      empty={
        <>
          An oracle computes the true contact forces for a trajectory. <Link to="/oracles/new">Create one.</Link>
        </>
      }
    />
  );
}
