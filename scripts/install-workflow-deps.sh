#!/usr/bin/env bash
# Installs the Debian packages of the batch workflow (workflow/Snakefile) and of
# its test (tests/workflow/test_workflow.sh): Snakemake, and Slurm with munge
# for the one-node cluster the test starts on localhost. Idempotent: does
# nothing when everything is already installed. Installing slurm-wlm and munge
# starts no daemon here (no systemd in CI); the test starts its own.
set -euo pipefail
PKGS=(snakemake slurm-wlm munge)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-workflow-deps: all ${#PKGS[@]} packages present"
  exit 0
fi
echo "install-workflow-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
