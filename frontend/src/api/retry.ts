/**
 * Which failed reads to try again: a busy or briefly unreachable server (503 "database busy,
 * retry", 502, 504, 429, network errors) a few times with backoff; client errors never.
 */
const TRANSIENT = new Set([0, 429, 502, 503, 504]);

export function shouldRetry(failureCount: number, error: unknown): boolean {
  const status = (error as { status?: number } | null)?.status;
  if (status === undefined) return failureCount < 1;
  if (TRANSIENT.has(status)) return failureCount < 5;
  return false;
}

export function retryDelay(attempt: number): number {
  return Math.min(200 * 2 ** attempt, 3000);
}

/** Writes are retried only when the server said the transaction did not happen (503 busy). */
export function shouldRetryWrite(failureCount: number, error: unknown): boolean {
  return (error as { status?: number } | null)?.status === 503 && failureCount < 5;
}
