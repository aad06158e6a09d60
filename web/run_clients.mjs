// Load usdworld exports with three.js in headless Chromium and print what three.js saw, as JSON.
//
//   node run_clients.mjs --dist DIR [--screenshots DIR] gltf=FILE.glb usdz=FILE.usdz ...
//
// DIR is the bundled page (node build.mjs --outdir DIR). The page and the files are served on
// 127.0.0.1 (an ephemeral port); nothing else is reached. Chromium is Debian's /usr/bin/chromium
// (override with USDWORLD_CHROMIUM), driven by playwright-core with a fresh user-data-dir.
import { createServer } from 'node:http';
import { mkdtempSync, readFileSync, rmSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { basename, extname, join, resolve } from 'node:path';
import { chromium } from 'playwright-core';

const CHROMIUM_FLAGS = [
  '--headless',
  '--no-sandbox',
  '--disable-gpu',
  '--disable-background-networking',
  '--disable-component-update',
  '--disable-default-apps',
  '--disable-sync',
  '--no-first-run',
  '--no-default-browser-check',
  '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader',
];
const TYPES = {
  '.html': 'text/html; charset=utf-8',
  '.js': 'text/javascript; charset=utf-8',
  '.glb': 'model/gltf-binary',
  '.usdz': 'model/vnd.usdz+zip',
};

function parseArgs(argv) {
  const out = { dist: null, screenshots: null, models: [] };
  for (let i = 0; i < argv.length; i += 1) {
    const a = argv[i];
    if (a === '--dist') out.dist = resolve(argv[++i]);
    else if (a === '--screenshots') out.screenshots = resolve(argv[++i]);
    else if (a.includes('=')) {
      const [kind, file] = [a.slice(0, a.indexOf('=')), a.slice(a.indexOf('=') + 1)];
      out.models.push({ kind, file: resolve(file) });
    } else throw new Error(`unexpected argument ${a}`);
  }
  if (!out.dist) throw new Error('--dist DIR is required');
  return out;
}

function serve(dist, models) {
  const files = new Map();
  models.forEach((m, i) => files.set(`/files/${i}/${basename(m.file)}`, m.file));
  const server = createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://127.0.0.1').pathname);
    const path = files.get(url) ?? (url === '/' ? join(dist, 'index.html') : join(dist, url.replace(/^\/+/, '')));
    if (!path.startsWith(dist) && !files.has(url)) {
      res.writeHead(403).end();
      return;
    }
    try {
      statSync(path);
      res.writeHead(200, { 'content-type': TYPES[extname(path)] ?? 'application/octet-stream' });
      res.end(readFileSync(path));
    } catch {
      res.writeHead(404).end();
    }
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok(server)));
}

async function main() {
  const args = parseArgs(process.argv.slice(2));
  const executablePath = process.env.USDWORLD_CHROMIUM || '/usr/bin/chromium';
  const server = await serve(args.dist, args.models);
  const base = `http://127.0.0.1:${server.address().port}`;
  const profile = mkdtempSync(join(tmpdir(), 'usdworld-chromium-'));
  const consoleLines = [];
  let context;
  try {
    context = await chromium.launchPersistentContext(profile, {
      executablePath,
      headless: true,
      args: CHROMIUM_FLAGS,
      viewport: { width: 800, height: 450 },
      timeout: 30000,
    });
    const page = context.pages()[0] ?? (await context.newPage());
    page.on('console', (msg) => consoleLines.push(`${msg.type()}: ${msg.text()}`));
    page.on('pageerror', (err) => consoleLines.push(`pageerror: ${err.message}`));
    await page.goto(`${base}/`, { timeout: 20000 });
    await page.waitForFunction(() => window.usdworldReady === true, null, { timeout: 20000 });
    const results = [];
    for (const [i, m] of args.models.entries()) {
      const url = `/files/${i}/${basename(m.file)}`;
      try {
        const summary = await page.evaluate(([u, k]) => window.usdworldLoad(u, k), [url, m.kind]);
        if (args.screenshots) {
          await page.screenshot({ path: join(args.screenshots, `${basename(m.file)}.png`) });
        }
        results.push({ file: m.file, kind: m.kind, ok: true, ...summary });
      } catch (err) {
        results.push({ file: m.file, kind: m.kind, ok: false, error: String(err.message ?? err) });
      }
    }
    const version = context.browser()?.version() ?? (await page.evaluate(() => navigator.userAgent));
    process.stdout.write(JSON.stringify({ chromium: version, results, console: consoleLines }));
  } finally {
    if (context) await context.close();
    server.close();
    rmSync(profile, { recursive: true, force: true });
  }
}

main().catch((err) => {
  process.stderr.write(`run_clients: ${err.stack ?? err}\n`);
  process.exit(1);
});
