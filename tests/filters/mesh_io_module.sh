#!/bin/sh
# The mesh I/O module as a process sees it (filters/src/mesh_files.hpp): commands that read and
# write no mesh never load VTK's I/O libraries (LD_DEBUG=libs lists every library a process opens,
# dlopen'd ones included); reading a model opens the module from EXE_DIR/../lib/echoreg, which is
# also where an installation puts it; without it, reading a model fails with exit 1 and an error
# naming the path it looked at, while detect still runs.
# Usage: mesh_io_module.sh ECHOREG MODULE CAPTURE STUDY WORKDIR (STUDY: a simulated study)
set -eu
echoreg=$1 module=$2 capture=$3 study=$4 work=$5
. "$(dirname "$0")/../support/module_process.sh"

rm -rf "$work" && mkdir -p "$work" && cd "$work"

# Commands that read and write no mesh.
never_loaded_by_version_and_detect "$echoreg" "$capture" libvtkIOXML- libvtkIOGeometry libvtkIOPLY \
  libvtkIOImage libpng libtiff libechoreg_mesh_io

# register reads its model (the module loads), then stops at the points file that is not there.
register() {  # register ECHOREG: the run's exit status; stderr in register.err
  status=0
  LD_DEBUG=libs "$1" register --model "$study/truth/femur.vtp" --bone Femur \
    --points "$work/no-such-points.csv" --initial "$study/truth/FemurToCT.json" \
    --out "$work/register.json" > register.out 2> register.libs || status=$?
  grep -v '^ *[0-9]*:' register.libs > register.err || true
  return "$status"
}
if register "$echoreg"; then fail "register succeeded without its points"; fi
loads libechoreg_mesh_io register.libs || fail "reading the model did not load the module"
grep -q "no-such-points.csv" register.err || fail "register did not read the model: $(cat register.err)"

# The installed layout: without the module, reading the model fails naming where it looked.
installed_layout "$echoreg"
refused_without_module "$module" register.json
cp "$module" prefix/lib/echoreg/
register "$work/prefix/bin/echoreg" || true
grep -q "no-such-points.csv" register.err ||
  fail "the installed layout did not read the model: $(cat register.err)"
echo "mesh I/O module: loaded only to read a model, found in the build tree and installed, missing named"
