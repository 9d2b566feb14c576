/// <reference types="vitest/config" />
import { defineConfig, type Plugin } from "vite";
import react from "@vitejs/plugin-react";
import { fileURLToPath } from "node:url";

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

export default defineConfig({
  plugins: [react(), preloadPlotly()],
  build: {
    outDir,
    emptyOutDir: true,
    chunkSizeWarningLimit: 5000,
  },
  server: {
    proxy: { "/api": apiTarget },
  },
  test: {
    environment: "jsdom",
    setupFiles: ["./src/test/setup.ts"],
    include: ["src/**/*.test.{ts,tsx}"],
    css: false,
  },
});
