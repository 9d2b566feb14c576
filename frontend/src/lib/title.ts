/** The browser tab's title of a page: "<what the page shows> · alcove", so tabs and history entries tell pages apart. */
import { useEffect } from "react";

export function pageTitle(title: string): string {
  return title ? `${title} · alcove` : "alcove";
}

export function useTitle(title: string): void {
  useEffect(() => {
    document.title = pageTitle(title);
  }, [title]);
}
