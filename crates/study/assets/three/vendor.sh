#!/bin/sh
# Regenerates three-view.min.js: three.js and its OrbitControls from npm (pinned versions),
# the exports of entry.js only, bundled and minified by esbuild (pinned) into one classic script
# that defines the global THREE_VIEW. Checks the npm tarballs' SHA-256 and writes the output's
# into SHA256SUMS (a test in crates/study compares the committed file against it).
#
#   sh crates/study/assets/three/vendor.sh          # needs node + npm (the npm registry)
#
# Running it twice gives the same bytes (esbuild's output is deterministic).
set -eu
THREE=0.187.0
ESBUILD=0.28.2
THREE_TGZ_SHA256=ff540832ded0cfe919764d24a3d88f3e2a05f23303f876423e4f893841e90728
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
npm pack --silent "three@$THREE" >/dev/null
got=$(sha256sum "three-$THREE.tgz" | cut -d' ' -f1)
if [ "$got" != "$THREE_TGZ_SHA256" ]; then
    echo "error: three-$THREE.tgz has SHA-256 $got, expected $THREE_TGZ_SHA256" >&2
    exit 1
fi
npm init -y >/dev/null
npm install --silent --no-save --no-audit --no-fund "./three-$THREE.tgz" "esbuild@$ESBUILD" >/dev/null
cp "$here/entry.js" entry.js
./node_modules/.bin/esbuild entry.js --bundle --minify --format=iife --global-name=THREE_VIEW \
    --legal-comments=none --log-level=warning --outfile=bundle.js
{
    printf '/* three.js %s (npm three@%s, MIT licence: crates/study/assets/three/LICENSE), WebGLRenderer and OrbitControls only, bundled by esbuild %s (crates/study/assets/three/vendor.sh) */\n' "r$(echo "$THREE" | cut -d. -f2)" "$THREE" "$ESBUILD"
    cat bundle.js
} > "$here/three-view.min.js"
cp node_modules/three/LICENSE "$here/LICENSE"
cd "$here"
{
    echo "$THREE_TGZ_SHA256  three-$THREE.tgz"
    sha256sum three-view.min.js
    sha256sum LICENSE
} > SHA256SUMS
cat SHA256SUMS
