#!/usr/bin/env bash
# Installs the Debian packages of the batch workflow (workflow/Snakefile) and of
# its test (tests/workflow/test_workflow.sh): Snakemake, and Slurm with munge
# for the one-node cluster the test starts on localhost. Idempotent. Installing
# slurm-wlm and munge starts no daemon here (no systemd in CI); the test starts
# its own.
set -euo pipefail
INSTALL_DEPS_NAME=install-workflow-deps exec bash "$(dirname "$0")/install-deps.sh" snakemake slurm-wlm munge
