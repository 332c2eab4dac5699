#!/usr/bin/env bash
# System packages pycolfrag needs: Open MPI from Debian (for mpi4py and mpirun).
# Skipped when mpirun and the MPI headers are already there. Uses sudo only when not root.
set -euo pipefail
if command -v mpirun >/dev/null 2>&1 && command -v mpicc >/dev/null 2>&1; then
    exit 0
fi
SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi
echo "setup_system: installing Open MPI from Debian (openmpi-bin libopenmpi-dev)"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq openmpi-bin libopenmpi-dev >/dev/null
