// The page's only way to psrigd: the documented HTTP API (daemon/README.md).
// The bearer token, when psrigd wants one, is asked for once, kept for the
// browser tab (sessionStorage) and sent as a header, never in a URL.

const TOKEN_KEY = 'psrig.token';

export class ApiError extends Error {
  constructor(status, code, message) {
    super(message);
    this.status = status;
    this.code = code;
  }
}

let tokenPrompt = null; // set by the page: async (reason) => token or null

export function onTokenNeeded(prompt) {
  tokenPrompt = prompt;
}

export function token() {
  return sessionStorage.getItem(TOKEN_KEY);
}

export function forgetToken() {
  sessionStorage.removeItem(TOKEN_KEY);
}

function headers(extra = {}) {
  const result = { ...extra };
  const t = token();
  if (t) result.Authorization = `Bearer ${t}`;
  return result;
}

async function errorOf(response) {
  let code = `http_${response.status}`;
  let message = `${response.status} ${response.statusText}`;
  try {
    const body = await response.json();
    // psrigd answers {"error": "what went wrong and the fix"}
    if (body && typeof body.error === 'string') message = body.error;
  } catch {
    // not JSON: keep the status line
  }
  return new ApiError(response.status, code, message);
}

// fetch() with the token; on 401 asks for a token (once per refusal) and
// tries again, so every caller simply awaits the answer.
export async function request(path, options = {}) {
  for (let attempt = 0; ; attempt++) {
    const response = await fetch(path, { ...options, headers: headers(options.headers) });
    if (response.status !== 401 || !tokenPrompt || attempt > 2) {
      if (!response.ok) throw await errorOf(response);
      return response;
    }
    const reason = token() ? 'psrigd refused this token.' : 'psrigd asks for a token.';
    const given = await tokenPrompt(reason);
    if (!given) throw await errorOf(response);
    sessionStorage.setItem(TOKEN_KEY, given);
  }
}

export async function getJson(path) {
  return (await request(path)).json();
}

export async function postJson(path, body) {
  const response = await request(path, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
  const text = await response.text();
  return text ? JSON.parse(text) : {};
}

// An image or any file the API serves, as an object URL an <img> can show
// (an <img src> cannot send the token). The caller revokes it when done.
export async function objectUrl(path) {
  const blob = await (await request(path)).blob();
  return URL.createObjectURL(blob);
}

export async function arrayBuffer(path) {
  return (await request(path)).arrayBuffer();
}

// Saves a file from the API under `filename` (a download link cannot carry
// the token either).
export async function download(path, filename) {
  const url = await objectUrl(path);
  const link = document.createElement('a');
  link.href = url;
  link.download = filename;
  document.body.append(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10_000);
}

// psrigd's server-sent events through fetch (EventSource cannot send a
// token): calls onEvent({event, data, id}) until the signal aborts;
// reconnects with Last-Event-ID after a dropped stream.
export async function followEvents(onEvent, signal) {
  let lastId = null;
  while (!signal.aborted) {
    try {
      const extra = lastId ? { 'Last-Event-ID': lastId } : {};
      const response = await request('/v1/events', { headers: extra, signal });
      const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
      let buffer = '';
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        buffer += value;
        let end;
        while ((end = buffer.indexOf('\n\n')) >= 0) {
          const block = buffer.slice(0, end);
          buffer = buffer.slice(end + 2);
          const message = { event: 'message', data: '', id: null };
          for (const line of block.split('\n')) {
            const colon = line.indexOf(':');
            if (colon <= 0) continue;
            const field = line.slice(0, colon);
            const text = line.slice(colon + 1).replace(/^ /, '');
            if (field === 'event') message.event = text;
            else if (field === 'data') message.data += (message.data ? '\n' : '') + text;
            else if (field === 'id') message.id = text;
          }
          if (message.id) lastId = message.id;
          if (message.data) {
            try {
              message.data = JSON.parse(message.data);
            } catch {
              // keep the text
            }
            onEvent(message);
          }
        }
      }
    } catch (error) {
      if (signal.aborted) return;
      if (error instanceof ApiError && error.status !== 503) throw error;
    }
    await new Promise((resolve) => setTimeout(resolve, 2000));
  }
}
