/// <reference types="vitest/config" />
import { defineConfig, type Plugin } from "vite";
import react from "@vitejs/plugin-react";
import { fileURLToPath } from "node:url";
import { readdirSync, readFileSync, statSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { brotliCompressSync, constants as zlib, gzipSync } from "node:zlib";

const outDir = fileURLToPath(new URL("../backend/alcove/static", import.meta.url));
const apiTarget = process.env.ALCOVE_API_URL ?? "http://127.0.0.1:8000";

/** Start fetching and compiling plotly.js together with the app (it is most of the bytes). */
function preloadPlotly(): Plugin {
  return {
    name: "alcove-preload-plotly",
    apply: "build",
    transformIndexHtml: {
      order: "post",
      handler(_html, ctx) {
        const chunk = Object.values(ctx.bundle ?? {}).find((c) => c.type === "chunk" && /plotly/.test(c.fileName));
        return chunk ? [{ tag: "link", attrs: { rel: "modulepreload", crossorigin: true, href: `/${chunk.fileName}` }, injectTo: "head" }] : [];
      },
    },
  };
}

/**
 * Precompress the build: `name.br` and `name.gz` next to every text file over 1 KiB. The API
 * (backend/alcove/api/static.py) sends them with Content-Encoding when the browser accepts
 * it, so the 1.2 MB plotly.js chunk crosses the wire as about 0.3 MB, with no work per request.
 */
function precompress(): Plugin {
  const compressible = /\.(js|mjs|css|html|svg|json|txt|map)$/;
  const walk = (dir: string): string[] =>
    readdirSync(dir, { withFileTypes: true }).flatMap((e) => (e.isDirectory() ? walk(join(dir, e.name)) : [join(dir, e.name)]));
  return {
    name: "alcove-precompress",
    apply: "build",
    closeBundle() {
      for (const file of walk(outDir)) {
        if (!compressible.test(file) || statSync(file).size < 1024) continue;
        const body = readFileSync(file);
        writeFileSync(`${file}.gz`, gzipSync(body, { level: 9 }));
        writeFileSync(
          `${file}.br`,
          brotliCompressSync(body, { params: { [zlib.BROTLI_PARAM_QUALITY]: 11, [zlib.BROTLI_PARAM_SIZE_HINT]: body.length } }),
        );
      }
    },
  };
}

export default defineConfig({
  plugins: [react(), preloadPlotly(), precompress()],
  build: {
    outDir,
    emptyOutDir: true,
    chunkSizeWarningLimit: 1500,
  },
  server: {
    proxy: { "/api": apiTarget },
  },
  test: {
    environment: "jsdom",
    setupFiles: ["./src/test/setup.ts"],
    include: ["src/**/*.test.{ts,tsx}"],
    css: false,
    // worker threads instead of child processes: the jsdom environment starts faster (67 s -> 50 s for the
    // whole run on the 2-core development machine); each file keeps its own isolated environment
    pool: "threads",
  },
});
