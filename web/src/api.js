// The server's JSON API (docs/explore.md). Every call rejects with an ApiError carrying the
// status and the server's message.

export class ApiError extends Error {
  constructor(status, body) {
    super(body.error || `HTTP ${status}`);
    this.status = status;
    this.body = body;
  }
  // A preview that a newer one (or Stop) ended: not an error to show.
  get cancelled() { return this.status === 409 && this.body.cancelled === true; }
}

async function request(method, path, body, signal) {
  const init = { method, signal, headers: {} };
  if (body !== undefined) {
    init.body = typeof body === 'string' ? body : JSON.stringify(body);
    init.headers['Content-Type'] = 'application/json';
  }
  const response = await fetch(path, init);
  if (!response.ok) {
    let parsed = {};
    try { parsed = await response.json(); } catch (e) { parsed = { error: response.statusText }; }
    throw new ApiError(response.status, parsed);
  }
  return response;
}

async function json(method, path, body, signal) {
  return (await request(method, path, body, signal)).json();
}

export const api = {
  info: () => json('GET', '/api/info'),
  presets: () => json('GET', '/api/presets'),
  // `params`: an object or the raw text of a parameter file.
  check: (params, signal) => json('POST', '/api/check', params, signal),
  // The mesh as GLB bytes and its figures.
  async mesh(params, signal) {
    const response = await request('POST', '/api/mesh', params, signal);
    const figures = JSON.parse(response.headers.get('X-Qjulia-Stats') || '{}');
    return { glb: await response.arrayBuffer(), figures };
  },
  compare: (a, b, samples, signal) => json('POST', '/api/compare', { a, b, samples }, signal),
  stopPreview: () => json('POST', '/api/preview/cancel', ''),
  startExport: (params, format) => json('POST', '/api/export', { params, format }),
  exportStatus: (id) => json('GET', `/api/export/${id}`),
  cancelExport: (id) => json('POST', `/api/export/${id}/cancel`, ''),
};
