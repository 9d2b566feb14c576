/** The list page of a kind of definition (tasks, oracles): title, "New" link, table with loading, empty and error states. */
import type { ReactNode } from "react";
import { Link } from "react-router-dom";
import type { UseQueryResult } from "@tanstack/react-query";
import { Empty, ErrorBox, Loading } from "./States";
import { fmtDate } from "../lib/format";
import { useTitle } from "../lib/title";

export interface Column<T> {
  header: string;
  num?: boolean;
  cell: (row: T) => ReactNode;
}

interface Row {
  id: number;
  name: string;
  version: number;
  owner?: string | null;
  updated_at: string;
}

export function DefinitionListPage<T extends Row>({ title, path, noun, query, columns, empty }: { title: string; path: string; noun: string; query: UseQueryResult<T[]>; columns: Column<T>[]; empty: ReactNode }) {
  useTitle(title);
  return (
    <>
      <div className="toolbar">
        <h1 style={{ margin: 0 }}>{title}</h1>
        <span className="spacer" />
        <Link className="button primary" to={`${path}/new`}>
          New {noun}
        </Link>
      </div>
      <div className="panel">
        {query.isPending ? (
          <Loading />
        ) : query.isError ? (
          <ErrorBox error={query.error} retry={() => void query.refetch()} />
        ) : query.data.length === 0 ? (
          <Empty title={`No ${title.toLowerCase()} yet`}>{empty}</Empty>
        ) : (
          <table>
            <thead>
              <tr>
                <th>Name</th>
                {columns.map((c) => (
                  <th key={c.header} className={c.num ? "num" : undefined}>
                    {c.header}
                  </th>
                ))}
                <th className="num">Version</th>
                <th>Owner</th>
                <th>Updated</th>
              </tr>
            </thead>
            <tbody>
              {query.data.map((row) => (
                <tr key={row.id}>
                  <td>
                    <Link to={`${path}/${row.id}`}>{row.name}</Link>
                  </td>
                  {columns.map((c) => (
                    <td key={c.header} className={c.num ? "num" : undefined}>
                      {c.cell(row)}
                    </td>
                  ))}
                  <td className="num">{row.version}</td>
                  <td>{row.owner ?? "—"}</td>
                  <td>{fmtDate(row.updated_at)}</td>
                </tr>
              ))}
            </tbody>
          </table>
        )}
      </div>
    </>
  );
}
