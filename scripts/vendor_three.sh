#!/usr/bin/env bash
# Vendor three.js (npm package `three`) into the web viewer's assets, with its licence.
# Run when upgrading three: bash scripts/vendor_three.sh [VERSION]; commit the result.
set -euo pipefail
version="${1:-0.187.0}"
root="$(cd "$(dirname "$0")/.." && pwd)"
dest="$root/src/terrascape/export/web_assets/three"
work="${TERRASCAPE_NODE_CACHE:-$HOME/.cache/terrascape/node}"
mkdir -p "$work" "$dest"
# Node trusts only its built-in certificates; add the system's (a proxy's or company's CA).
if [ -z "${NODE_EXTRA_CA_CERTS:-}" ] && [ -f /etc/ssl/certs/ca-certificates.crt ]; then
  export NODE_EXTRA_CA_CERTS=/etc/ssl/certs/ca-certificates.crt
fi
npm install --no-audit --no-fund --prefix "$work" "three@$version" >/dev/null
src="$work/node_modules/three"
cp "$src/build/three.core.js" "$src/build/three.module.js" "$dest/"
cp "$src/examples/jsm/loaders/GLTFLoader.js" "$src/examples/jsm/controls/OrbitControls.js" \
  "$src/examples/jsm/utils/BufferGeometryUtils.js" "$src/examples/jsm/utils/SkeletonUtils.js" \
  "$src/examples/jsm/libs/meshopt_decoder.module.js" "$dest/"
cp "$src/LICENSE" "$dest/LICENSE"
echo "three $(node -p "require('$src/package.json').version")" > "$dest/VERSION"
echo "vendored three into $dest"
