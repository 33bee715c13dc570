#!/usr/bin/env bash
# One command on a fresh Debian machine: install dependencies, build, run the demo.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
./build/shadowsg demo --out demo-out
