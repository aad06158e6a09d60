#!/usr/bin/env bash
# Build the page of `usdworld serve` (webapp/ -> usdworld/serve/static/, committed).
# Installs webapp/'s npm packages exactly as locked (three, esbuild) when node_modules is
# missing or stale, then bundles. Safe to run twice; needs node >= 18 and npm.
#   tools/build_webapp.sh           build into usdworld/serve/static
#   tools/build_webapp.sh --check   build into a temporary folder and fail if the committed
#                                   files differ (someone edited webapp/src without building)
set -euo pipefail
cd "$(dirname "$0")/../webapp"

check=0
for arg in "$@"; do
  case "$arg" in
    --check) check=1 ;;
    *) echo "usage: tools/build_webapp.sh [--check]" >&2; exit 2 ;;
  esac
done

command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1 || {
  echo "error: node and npm are needed (Debian: apt-get install -y nodejs npm)" >&2
  exit 1
}

# npm ci wipes node_modules: only when it does not match package-lock.json
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

if [ "$check" = 1 ]; then
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  node build.mjs --out "$tmp" >/dev/null
  if ! diff -r "$tmp" ../usdworld/serve/static >/dev/null; then
    diff -rq "$tmp" ../usdworld/serve/static >&2 || true
    echo "error: usdworld/serve/static is out of date with webapp/src; run tools/build_webapp.sh and commit" >&2
    exit 1
  fi
  echo "usdworld/serve/static is up to date with webapp/src"
else
  node build.mjs
fi
