#!/usr/bin/env bash
# Install what the browser-client and glTF-validator tests need, on a fresh Debian machine:
#   - Debian's chromium (/usr/bin/chromium), driven headless by playwright-core;
#   - node >= 20 with npm (kept if present; Debian's own nodejs is 18, too old for playwright-core);
#   - web/'s npm packages exactly as pinned in web/package-lock.json (three, playwright-core,
#     esbuild, gltf-validator), then the bundled test page in web/dist.
# Safe to run twice: installed packages are skipped, npm ci only runs when node_modules is stale.
set -euo pipefail
cd "$(dirname "$0")/.."

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

apt_packages=(chromium)
command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1 || apt_packages+=(nodejs npm)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

node_major=$(node -p 'process.versions.node.split(".")[0]')
if [ "$node_major" -lt 20 ]; then
  echo "error: node $(node --version) is too old; playwright-core in web/package.json needs node >= 20" >&2
  exit 1
fi

cd web
# npm ci wipes and reinstalls node_modules: only when it does not match the lock file
stale=0
[ -f node_modules/.package-lock.json ] || stale=1
[ "$stale" = 0 ] && [ package-lock.json -nt node_modules/.package-lock.json ] && stale=1
[ "$stale" = 0 ] && ! node -e '
  const deps = require("./package.json").devDependencies;
  for (const [name, version] of Object.entries(deps)) {
    if (require(`./node_modules/${name}/package.json`).version !== version) process.exit(1);
  }' >/dev/null 2>&1 && stale=1
if [ "$stale" = 1 ]; then
  npm ci --no-audit --no-fund --loglevel=error
fi
node build.mjs >/dev/null
echo "web tools ready: $(/usr/bin/chromium --version 2>/dev/null | head -1), node $(node --version), page in web/dist"
