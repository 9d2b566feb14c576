/**
 * The typed API client (openapi-fetch over the generated `paths` of src/api/schema.d.ts).
 * Adds the bearer token and turns non-2xx answers into ApiError.
 */
import createClient, { type Middleware } from "openapi-fetch";
import type { components, paths } from "./schema";
import { ApiError } from "./errors";
import { storedToken } from "./auth";

export const UNAUTHORIZED_EVENT = "alcove:unauthorized";

const auth: Middleware = {
  onRequest({ request }) {
    const token = storedToken();
    if (token && !request.headers.has("Authorization")) request.headers.set("Authorization", `Bearer ${token}`);
    return request;
  },
  onResponse({ response }) {
    if (response.status === 401) window.dispatchEvent(new Event(UNAUTHORIZED_EVENT));
    return response;
  },
};

export const client = createClient<paths>({
  baseUrl: typeof window === "undefined" ? "http://localhost" : window.location.origin,
  // resolved per call (tests replace the global fetch)
  fetch: (request: Request) => globalThis.fetch(request),
});
client.use(auth);

/** The data of an openapi-fetch answer, or an ApiError. */
export function unwrap<T>(result: { data?: T; error?: unknown; response: Response }): T {
  if (result.error !== undefined || !result.response.ok) throw new ApiError(result.response.status, result.error);
  return result.data as T;
}

/** A build of the model artifact zips a download waits for (the API answered 202). */
export type ArtifactBuild = components["schemas"]["ArtifactBuildRead"];

/** How often a download polls the build it waits for, unless the 202's Retry-After says otherwise. */
const BUILD_POLL_MS = 1000;

const sleep = (ms: number) => new Promise((resolve) => setTimeout(resolve, ms));

async function authorizedFetch(path: string): Promise<Response> {
  const token = storedToken();
  const response = await fetch(path, { headers: token ? { Authorization: `Bearer ${token}` } : {} });
  if (!response.ok) {
    let body: unknown = null;
    try {
      body = await response.json();
    } catch {
      /* not JSON */
    }
    throw new ApiError(response.status, body);
  }
  return response;
}

/** Follow a build until it is ready (each state to ``onBuild``); a failed build is an error naming why. */
async function waitForBuild(location: string, first: ArtifactBuild, pollMs: number, onBuild: (build: ArtifactBuild) => void): Promise<void> {
  let build = first;
  for (;;) {
    onBuild(build);
    if (build.status === "ready") return;
    if (build.status === "failed") throw new Error(build.error ?? "the build failed");
    await sleep(pollMs);
    build = (await (await authorizedFetch(location)).json()) as ArtifactBuild;
  }
}

/**
 * Download a file from an authenticated route (browsers do not send bearer tokens on <a href>).
 * A download whose model zips a worker must build first answers 202 with the build: it is
 * followed (``onBuild`` gets each state, for a progress display) and the download repeated once
 * it is ready.
 */
export async function downloadFile(path: string, filename: string, onBuild: (build: ArtifactBuild) => void = () => {}): Promise<void> {
  let response = await authorizedFetch(path);
  while (response.status === 202) {
    const build = (await response.json()) as ArtifactBuild;
    const location = response.headers.get("Location") ?? `/api/v1/campaigns/${build.campaign_id}/artifact-builds/${build.id}`;
    const retryAfter = Number(response.headers.get("Retry-After") ?? NaN);
    await waitForBuild(location, build, Number.isFinite(retryAfter) ? retryAfter * 1000 : BUILD_POLL_MS, onBuild);
    response = await authorizedFetch(path);
  }
  const disposition = response.headers.get("Content-Disposition") ?? "";
  const match = /filename\*?=(?:UTF-8'')?"?([^";]+)"?/i.exec(disposition);
  const blob = await response.blob();
  const url = URL.createObjectURL(blob);
  const a = document.createElement("a");
  a.href = url;
  a.download = match ? decodeURIComponent(match[1]) : filename;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10_000);
}
