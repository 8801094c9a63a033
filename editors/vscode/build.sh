#!/usr/bin/env bash
# Build labsim.vsix: the schemas from the labsim on the PATH, the packages from package-lock.json,
# then @vscode/vsce. Run from anywhere; needs node, npm and labsim.
set -euo pipefail
cd "$(dirname "$0")"
mkdir -p schemas
for kind in behaviour world assignment; do
    labsim schema "$kind" > "schemas/$kind.schema.json"
done
npm ci --no-audit --no-fund
npx --no-install vsce package --allow-missing-repository --out labsim.vsix
