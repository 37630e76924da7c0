#!/usr/bin/env bash
# Validates glTF files with the Khronos glTF validator (npm gltf-validator, pinned in
# scripts/gltf/package-lock.json): installs the pinned packages with `npm ci` on first use, then
# prints the report of every file and exits non-zero when any has an error.
#   usage: scripts/validate_gltf.sh FILE.gltf|FILE.glb …
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
command -v node >/dev/null || { echo "validate_gltf.sh: node is not installed" >&2; exit 3; }
if [ ! -d "$here/gltf/node_modules/gltf-validator" ] || [ ! -d "$here/gltf/node_modules/three" ]; then
  (cd "$here/gltf" && npm ci --no-audit --no-fund --silent) >&2
fi
exec node "$here/gltf/validate.mjs" "$@"
