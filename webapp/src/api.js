// The JSON API of `usdworld serve` (usdworld/serve/app.py). Every request carries the
// session token from the page's URL in the X-Usdworld-Token header.

export const token = new URLSearchParams(window.location.search).get('token') || '';

export class ApiError extends Error {
  constructor(status, message, body) {
    super(message);
    this.status = status;
    this.body = body;
  }
}

function headers(extra = {}) {
  return { 'X-Usdworld-Token': token, ...extra };
}

async function errorOf(response) {
  let body = {};
  try {
    body = await response.json();
  } catch (_) {
    body = { error: `${response.status} ${response.statusText}` };
  }
  return new ApiError(response.status, body.error || response.statusText, body);
}

/** GET a JSON document; throws ApiError unless 2xx. */
export async function getJSON(path) {
  const response = await fetch(path, { headers: headers(), cache: 'no-store' });
  if (!response.ok) throw await errorOf(response);
  return response.json();
}

/** GET binary data: {buffer, version}. */
export async function getBinary(path) {
  const response = await fetch(path, { headers: headers(), cache: 'no-store' });
  if (!response.ok) throw await errorOf(response);
  return { buffer: await response.arrayBuffer(), version: response.headers.get('x-usdworld-version') };
}

/** POST an operation; resolves to {ok, status, body} (refusals are not exceptions). */
export async function post(op, body = {}) {
  const response = await fetch(`/api/${op}`, {
    method: 'POST',
    headers: headers({ 'Content-Type': 'application/json' }),
    body: JSON.stringify(body),
  });
  let data = {};
  try {
    data = await response.json();
  } catch (_) {
    data = { error: `${response.status} ${response.statusText}` };
  }
  return { ok: response.ok, status: response.status, body: data };
}

/** A URL for <img src> (GET requests may carry the token as a query parameter). */
export function withToken(path) {
  return `${path}${path.includes('?') ? '&' : '?'}token=${encodeURIComponent(token)}`;
}
