import type { ReactElement } from "react";
import { render } from "@testing-library/react";
import { MemoryRouter, Route, Routes, useLocation } from "react-router-dom";
import { QueryClient, QueryClientProvider } from "@tanstack/react-query";
import { vi } from "vitest";
import { AuthProvider } from "../api/auth";

export type Handler = (url: URL, body: any) => unknown | Response; // eslint-disable-line @typescript-eslint/no-explicit-any

/** Replace fetch with a table of handlers keyed "METHOD /path" (path after /api/v1). */
export function mockApi(routes: Record<string, Handler | unknown>) {
  const calls: { method: string; path: string; url: URL; body: unknown }[] = [];
  const fetchMock = vi.fn(async (input: RequestInfo | URL, init: RequestInit = {}) => {
    const req = input instanceof Request ? input : null;
    const url = new URL(req ? req.url : String(input), "http://localhost");
    const method = (req?.method ?? init.method ?? "GET").toUpperCase();
    const path = url.pathname.replace(/^\/api\/v1/, "");
    const rawBody = req ? await req.clone().text() : (init.body as string | undefined);
    const body = rawBody ? JSON.parse(rawBody) : undefined;
    calls.push({ method, path, url, body });
    const key = `${method} ${path}`;
    const match = Object.entries(routes).find(([pattern]) => new RegExp(`^${pattern.replace(/\{[^}]+\}/g, "[^/]+")}$`).test(key));
    if (!match) return new Response(JSON.stringify({ detail: `no mock for ${key}` }), { status: 404 });
    const value = await (typeof match[1] === "function" ? (match[1] as Handler)(url, body) : match[1]);
    if (value instanceof Response) return value;
    return new Response(JSON.stringify(value), { status: 200, headers: { "Content-Type": "application/json" } });
  });
  vi.stubGlobal("fetch", fetchMock);
  return { calls, fetchMock };
}

export function jsonResponse(body: unknown, status = 200): Response {
  return new Response(JSON.stringify(body), { status, headers: { "Content-Type": "application/json" } });
}

/**
 * A server-sent event stream the test writes to: `send(event)` writes one frame, `close()`
 * ends the stream (as the server's timeout or a terminal campaign does). `response()` is what
 * the mocked route answers; each call opens a new connection (reconnects are counted).
 */
export function sseStream() {
  const controllers: ReadableStreamDefaultController<Uint8Array>[] = [];
  const encoder = new TextEncoder();
  let id = 0;
  const write = (text: string) => {
    for (const c of controllers) {
      try {
        c.enqueue(encoder.encode(text));
      } catch {
        /* closed */
      }
    }
  };
  return {
    connections: 0,
    /** the next connections are told `complete: false` even when resuming (more missed events than the server keeps) */
    incomplete: false,
    /** answers a connection as the server does: missed events (none here), then `ready` (complete only when resuming with ?after=) */
    response(url?: URL): Response {
      this.connections += 1;
      const complete = Boolean(url?.searchParams.get("after")) && !this.incomplete;
      const body = new ReadableStream<Uint8Array>({
        start: (c) => {
          controllers.push(c);
          c.enqueue(encoder.encode(`id: ${id}\nevent: ready\ndata: ${JSON.stringify({ last_event_id: id, complete })}\n\n`));
        },
      });
      return new Response(body, { status: 200, headers: { "Content-Type": "text/event-stream" } });
    },
    send(e: { kind: string; campaign_id?: number; iteration_index?: number | null; step?: string | null; message?: string; data?: Record<string, unknown> }) {
      id += 1;
      const ev = { id, campaign_id: 7, iteration_index: null, step: null, message: "", data: {}, created_at: "2026-11-21T22:00:00Z", ...e };
      write(`id: ${id}\nevent: ${ev.kind}\ndata: ${JSON.stringify(ev)}\n\n`);
      return id;
    },
    comment() {
      write(": keep-alive\n\n");
    },
    close() {
      for (const c of controllers.splice(0)) {
        try {
          c.close();
        } catch {
          /* already closed */
        }
      }
    },
  };
}

function LocationProbe() {
  const location = useLocation();
  return <div data-testid="location" data-search={location.search} hidden />;
}

export function renderPage(ui: ReactElement, { route = "/", path = "*", token = "test-token" }: { route?: string; path?: string; token?: string | null } = {}) {
  if (token) localStorage.setItem("alcove.token", token);
  const client = new QueryClient({ defaultOptions: { queries: { retry: false, staleTime: 0 }, mutations: { retry: false } } });
  return {
    client,
    ...render(
      <QueryClientProvider client={client}>
        <AuthProvider>
          <MemoryRouter initialEntries={[route]}>
            <LocationProbe />
            <Routes>
              <Route path={path} element={ui} />
              <Route path="*" element={<div data-testid="elsewhere" />} />
            </Routes>
          </MemoryRouter>
        </AuthProvider>
      </QueryClientProvider>,
    ),
  };
}
