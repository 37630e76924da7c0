#!/usr/bin/env bash
# Loads a glTF/GLB file with three.js's GLTFLoader headless in Node (three and the
# KHR_animation_pointer plugin pinned in scripts/gltf/package-lock.json, installed with `npm ci` on
# first use) and prints what three.js made of it as JSON; with times, also the emission three.js's
# AnimationMixer computes at each time.
#   usage: scripts/gltf/load_three.sh FILE.gltf|FILE.glb [t_s,t_s,…]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
command -v node >/dev/null || { echo "load_three.sh: node is not installed" >&2; exit 3; }
if [ ! -d "$here/node_modules/three" ] || [ ! -d "$here/node_modules/@needle-tools/three-animation-pointer" ]; then
  (cd "$here" && npm ci --no-audit --no-fund --silent) >&2
fi
exec node "$here/load_three.mjs" "$@"
