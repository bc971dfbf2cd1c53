#!/usr/bin/env bash
# Create or reuse the project's virtual environment with the MPI + PETSc stack.
#
#   scripts/bootstrap.sh            # prints the path of the environment's python
#
# Order of preference for the stack (first that applies wins):
#   1. petsc4py and mpi4py importable from $PYTHON (or python3): the environment
#      is created with --system-site-packages and uses them;
#   2. PETSC_DIR (and PETSC_ARCH) set: petsc4py is built against that PETSc;
#   3. otherwise PETSc is built once from PyPI (optimised, no Fortran), then
#      petsc4py is built against it without build isolation.
# MPI: an `mpicc` already on PATH is used (mpi4py built from source against it);
# otherwise the `mpich` wheel from PyPI provides MPI.
# BLAS/LAPACK for the PETSc build: Debian's libopenblas-dev, installed when
# missing and this script runs as root.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv=${ROUGHCONTACT_VENV:-$root/.venv}
base_python=${PYTHON:-python3}
petsc_version=3.26.1
log() { echo "[setup] $*" >&2; }

user_mpicc=""
if command -v mpicc >/dev/null 2>&1 && [ "$(command -v mpicc)" != "$venv/bin/mpicc" ]; then
    user_mpicc=$(command -v mpicc)
fi

if [ ! -x "$venv/bin/python" ]; then
    # a stack importable from the base interpreter, and visible to a venv made from it
    # (not one installed inside another virtual environment)
    if "$base_python" -c "
import sys, petsc4py, mpi4py
inside_venv = sys.prefix != sys.base_prefix and petsc4py.__file__.startswith(sys.prefix)
sys.exit(1 if inside_venv else 0)" >/dev/null 2>&1; then
        log "using petsc4py and mpi4py importable from $base_python"
        "$base_python" -m venv --system-site-packages "$venv"
    else
        log "creating the virtual environment $venv"
        "$base_python" -m venv "$venv"
    fi
fi
vpy=$venv/bin/python
export PATH="$venv/bin:$PATH"

stamp=$venv/.roughcontact-installed
if [ -f "$stamp" ] && [ "$stamp" -nt "$root/pyproject.toml" ] \
   && "$vpy" -c "import petsc4py, mpi4py, roughcontact" >/dev/null 2>&1; then
    echo "$vpy"
    exit 0
fi

pip_install() { "$vpy" -m pip install --disable-pip-version-check -q "$@"; }
pip_install --upgrade pip setuptools wheel

# --- MPI ---------------------------------------------------------------------
if ! "$vpy" -c "import mpi4py" >/dev/null 2>&1; then
    if [ -n "$user_mpicc" ]; then
        log "building mpi4py against the MPI of $user_mpicc"
        MPICC=$user_mpicc pip_install --no-binary mpi4py mpi4py
    else
        log "installing MPI from the mpich wheel"
        pip_install mpich mpi4py
    fi
fi

# --- PETSc -------------------------------------------------------------------
ensure_blas() {
    if ldconfig -p 2>/dev/null | grep -q -E 'lib(openblas|lapack)\.so'; then return; fi
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        log "installing BLAS/LAPACK (libopenblas-dev)"
        apt-get update -qq >/dev/null
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libopenblas-dev >/dev/null
    else
        log "no BLAS/LAPACK found: install libopenblas-dev (or set PETSC_DIR to an existing PETSc)"
        exit 1
    fi
}

if ! "$vpy" -c "import petsc4py" >/dev/null 2>&1; then
    pip_install numpy cython
    if [ -n "${PETSC_DIR:-}" ]; then
        ver=$(awk '/define PETSC_VERSION_(MAJOR|MINOR) /{printf "%s.", $3}' "$PETSC_DIR/include/petscversion.h")
        log "building petsc4py ${ver}* against PETSC_DIR=$PETSC_DIR PETSC_ARCH=${PETSC_ARCH:-}"
        pip_install --no-build-isolation "petsc4py==${ver}*"
    else
        ensure_blas
        mpicc=${user_mpicc:-$venv/bin/mpicc}
        log "building PETSc $petsc_version once (about 10 minutes on 2 cores), MPI from $mpicc"
        MPICC=$mpicc MPICXX=${mpicc%cc}cxx \
        PETSC_CONFIGURE_OPTIONS="--with-fc=0 --with-x=0 --with-debugging=0 COPTFLAGS=-O3 CXXOPTFLAGS=-O3" \
            pip_install "petsc==$petsc_version"
        log "building petsc4py $petsc_version against it"
        pip_install --no-build-isolation "petsc4py==$petsc_version"
    fi
fi

# --- the package and its Python dependencies -----------------------------------
pip_install -e "$root[test,topography]"
touch "$stamp"
echo "$vpy"
