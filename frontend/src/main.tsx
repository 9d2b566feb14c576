import { StrictMode } from "react";
import { createRoot } from "react-dom/client";
import { BrowserRouter } from "react-router-dom";
import { QueryClient, QueryClientProvider } from "@tanstack/react-query";
import { AuthProvider } from "./api/auth";
import { App } from "./App";
import { shouldRetry, shouldRetryWrite, retryDelay } from "./api/retry";
import "./styles.css";
import { loadPlotly } from "./components/Plot";

// Pages with charts: start fetching and compiling plotly.js before React renders.
if (/^\/(campaigns\/\d+|compare)/.test(window.location.pathname)) void loadPlotly();

const queryClient = new QueryClient({
  defaultOptions: {
    queries: { staleTime: 1000, retry: shouldRetry, retryDelay, refetchOnWindowFocus: false },
    mutations: { retry: shouldRetryWrite, retryDelay },
  },
});

createRoot(document.getElementById("root")!).render(
  <StrictMode>
    <QueryClientProvider client={queryClient}>
      <AuthProvider>
        <BrowserRouter>
          <App />
        </BrowserRouter>
      </AuthProvider>
    </QueryClientProvider>
  </StrictMode>,
);
