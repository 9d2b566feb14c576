import type { QueryClient, QueryKey } from "@tanstack/react-query";

/**
 * Refetch the queries under `queryKey` after a write has committed. A fetch still in flight may
 * have read before the write, and React Query joins a refetch onto an in-flight fetch of a query
 * that has no data yet instead of restarting it (`cancelRefetch` only applies once a query has
 * data), so a list opened just before the write would keep its old answer. Cancelling first makes
 * the refetch a new request.
 */
export async function refetchAfterWrite(qc: QueryClient, queryKey: QueryKey): Promise<void> {
  await qc.cancelQueries({ queryKey });
  await qc.invalidateQueries({ queryKey });
}
