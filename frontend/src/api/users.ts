/** Sign-in, the signed-in user and their API tokens. */
import { useMutation, useQuery, useQueryClient } from "@tanstack/react-query";
import { client, unwrap } from "./client";
import { refetchAfterWrite } from "./refresh";
import { keys } from "./keys";
import type { Me, Token } from "./types";

/** Thrown for 429: too many failed sign-ins from this address (``retryAfterS``: seconds to wait). */
export class SignInThrottled extends Error {
  readonly retryAfterS: number;
  constructor(retryAfterS: number) {
    super(`Too many failed sign-ins from this address: try again in ${retryAfterS} s.`);
    this.retryAfterS = retryAfterS;
  }
}

export async function login(email: string, password: string): Promise<string> {
  const result = await client.POST("/api/v1/auth/login", { body: { email, password } });
  if (result.response.status === 429) throw new SignInThrottled(Number(result.response.headers.get("Retry-After")) || 1);
  return unwrap(result).access_token;
}

export function useMe() {
  return useQuery({ queryKey: keys.me, queryFn: async (): Promise<Me> => unwrap(await client.GET("/api/v1/me")), staleTime: 60_000 });
}

/** How the UI names a user: the display name, else the e-mail. */
export function userLabel(u: Pick<Me, "display_name" | "email">): string {
  return u.display_name || u.email;
}

export function useTokens() {
  return useQuery({ queryKey: keys.tokens, queryFn: async (): Promise<Token[]> => unwrap(await client.GET("/api/v1/me/tokens")) });
}

export function useCreateToken() {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (body: { name: string }) => unwrap(await client.POST("/api/v1/me/tokens", { body })),
    onSuccess: () => refetchAfterWrite(qc, keys.tokens),
  });
}

export function useRevokeToken() {
  const qc = useQueryClient();
  return useMutation({
    mutationFn: async (id: number) => {
      const r = await client.DELETE("/api/v1/me/tokens/{token_id}", { params: { path: { token_id: id } } });
      if (!r.response.ok) unwrap(r);
    },
    onSuccess: () => refetchAfterWrite(qc, keys.tokens),
  });
}
