// Formula families with a degree (QHD's "degree of the predefined maps") and the names a
// formula uses. A family writes formula text; the server compiles it like any other formula.

// "3*h^2" written without the parts that are 1.
function term(coefficient, power) {
  const c = coefficient === 1 ? '' : `${coefficient}*`;
  if (power === 0) return coefficient === 1 ? '1' : String(coefficient);
  return power === 1 ? `${c}h` : `${c}h^${power}`;
}

export const families = [
  {
    id: 'newton',
    name: "Newton's map for h^n - 1",
    // h - (h^n - 1) / (n h^(n-1)) = ((n-1) h^n + 1) / (n h^(n-1))
    text: (n) => `(${term(n - 1, n)}+1)/(${term(n, n - 1)})`,
    constants: {},
    method: 'cutoff',
  },
  {
    id: 'newton-c',
    name: "Newton's map for h^n - c",
    text: (n) => `(${term(n - 1, n)}+c)/(${term(n, n - 1)})`,
    constants: { c: [1, 0.3, 0, 0] },
    method: 'cutoff',
  },
  {
    id: 'power',
    name: 'h^n + c',
    text: (n) => `h^${n}+c`,
    constants: { c: [-0.2, 0.8, 0, 0] },
    method: 'escape',
  },
  {
    id: 'pq',
    name: 'p*h^n + q (the paper\'s ph^2 + q)',
    text: (n) => `p*h^${n}+q`,
    constants: { p: [0.9, 0.3, 0.2, 0.1], q: [-0.3, 0.5, 0.3, 0.1] },
    method: 'escape',
  },
  {
    id: 'inverse',
    name: 'h^n + c/h^n',
    text: (n) => `h^${n}+c/h^${n}`,
    constants: { c: [0.1, 0, 0, 0] },
    method: 'cutoff',
  },
];

export const kMinDegree = 2;
export const kMaxDegree = 12;

export function familyById(id) {
  return families.find((f) => f.id === id) || null;
}

// The family and degree that write `text` exactly, or null (a custom formula).
export function detectFamily(text) {
  const t = text.replace(/\s+/g, '');
  for (const f of families) {
    for (let n = kMinDegree; n <= kMaxDegree; ++n) {
      if (f.text(n) === t) return { family: f, degree: n };
    }
  }
  return null;
}

const kReserved = new Set(['h', 'i', 'j', 'k', 'conj', 'inv', 'norm', 'abs', 'sqr', 'exp', 'log',
  'sqrt', 'sin', 'cos', 'tan', 'sinh', 'cosh', 'tanh']);

// The constant names `text` uses, in order of appearance: identifiers that are neither the
// variable, a unit nor a function; numbers (1e-3, 0.8i) are skipped whole.
export function constantNames(text) {
  const names = [];
  const token = /(\d+\.?\d*|\.\d+)(e[+-]?\d+)?[ijk]?|[A-Za-z_][A-Za-z0-9_]*/gi;
  for (const m of text.matchAll(token)) {
    const word = m[0];
    if (/^[\d.]/.test(word) || kReserved.has(word) || names.includes(word)) continue;
    names.push(word);
  }
  return names;
}
