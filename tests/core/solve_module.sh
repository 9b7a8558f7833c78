#!/bin/sh
# The solver module as a process sees it (core/src/solve_calls.hpp): commands that solve nothing
# never load Ceres's libraries (LD_DEBUG=libs lists every library a process opens, dlopen'd ones
# included); a registration opens the module from EXE_DIR/../lib/echoreg, which is also where an
# installation puts it; without it, the registration fails with exit 1 and an error naming the
# path it looked at, writes nothing, while detect still runs.
# Usage: solve_module.sh ECHOREG MODULE CAPTURE STUDY WORKDIR (STUDY: a simulated study)
set -eu
echoreg=$1 module=$2 capture=$3 study=$4 work=$5
. "$(dirname "$0")/../support/module_process.sh"

rm -rf "$work" && mkdir -p "$work" && cd "$work"

# Commands that solve nothing: neither the module nor what Ceres brings.
never_loaded_by_version_and_detect "$echoreg" "$capture" libechoreg_solve libglog libcholmod \
  libcxsparse liblapack libf77blas libgfortran

# register's robust solver opens the module (and Ceres's libraries with it).
register() {  # register ECHOREG: the run's exit status; stderr in register.err
  status=0
  LD_DEBUG=libs "$1" register --model "$study/truth/femur.vtp" --bone Femur \
    --capture "$study/captures/femur_ultrasound.igs.mha" \
    --calibration "$study/truth/BeamToProbe.json" --initial "$study/truth/FemurToCT.json" \
    --out "$work/register.json" > register.out 2> register.libs || status=$?
  grep -v '^ *[0-9]*:' register.libs > register.err || true
  return "$status"
}
register "$echoreg" || fail "register failed: $(cat register.err)"
loads libechoreg_solve register.libs || fail "the registration did not load the module"
loads libglog register.libs || fail "the module did not bring Ceres's libraries"
cp register.json register-build-tree.json
rm -f register.json register.tfm

# The installed layout: without the module, the registration fails naming where it looked.
installed_layout "$echoreg"
cp "$(dirname "$echoreg")/../lib/echoreg/libechoreg_mesh_io.so" prefix/lib/echoreg/
refused_without_module "$module" register.json
cp "$module" prefix/lib/echoreg/
register "$work/prefix/bin/echoreg" || fail "the installed layout did not register: $(cat register.err)"
cmp -s register.json register-build-tree.json ||
  fail "the installed layout registered other bytes than the build tree"
echo "solver module: loaded only to solve, found in the build tree and installed, missing named"
