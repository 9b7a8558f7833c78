#!/bin/sh
# The renderer module as a process sees it (render/renderer_module.hpp): commands that draw
# nothing never load OSMesa or LLVM (LD_DEBUG=libs lists every library a process opens, dlopen'd
# ones included); a figure opens the module from EXE_DIR/../lib/echoreg, which is also where an
# installation puts it, also through a symbolic link to the executable; without the module a
# figure fails with exit 1, an error naming the path it looked at and no output file, while the
# other commands still run.
# Usage: renderer_module.sh ECHOREG MODULE CAPTURE WORKDIR
set -eu
echoreg=$1 module=$2 capture=$3 work=$4
. "$(dirname "$0")/../support/module_process.sh"

rm -rf "$work" && mkdir -p "$work" && cd "$work"
printf 'estimate,error_mm\na,0.24\nb,0.31\nc,0.18\nd,0.45\n' > a.csv
printf 'estimate,error_mm\na,0.52\nb,0.61\nc,0.47\nd,0.70\n' > b.csv

# Commands that draw nothing.
never_loaded_by_version_and_detect "$echoreg" "$capture" libOSMesa libLLVM libGLX \
  libvtkRenderingOpenGL2 libechoreg_render_gl

# A figure loads the module, and OSMesa with it.
LD_DEBUG=libs "$echoreg" figure boxplot --group A=a.csv --group B=b.csv --out box.png \
  > figure.out 2> figure.libs || fail "figure boxplot failed: $(grep -v '^ *[0-9]*:' figure.libs)"
loads libechoreg_render_gl figure.libs || fail "figure boxplot did not load the module"
loads libOSMesa figure.libs || fail "figure boxplot did not load libOSMesa"
[ -s box.png ] || fail "no box.png"

# The installed layout: PREFIX/bin/echoreg finds PREFIX/lib/echoreg/ and draws the same pixels.
mkdir -p prefix/bin prefix/lib/echoreg
cp "$echoreg" prefix/bin/echoreg
"$work/prefix/bin/echoreg" --version > /dev/null || fail "the copied echoreg does not start"
exits_1_naming "$work/prefix/lib/echoreg/$(basename "$module")" \
  "figure boxplot without the module" missing.err \
  "$work/prefix/bin/echoreg" figure boxplot --group A=a.csv --group B=b.csv --out missing.png
[ ! -e missing.png ] || fail "missing.png written without the module"
cp "$module" prefix/lib/echoreg/
"$work/prefix/bin/echoreg" figure boxplot --group A=a.csv --group B=b.csv --out installed.png \
  > installed.out 2> installed.err || fail "the installed layout failed: $(cat installed.err)"
cmp -s box.png installed.png || fail "the installed layout drew other pixels"
# A symbolic link to the executable finds the module beside the executable itself.
mkdir -p elsewhere && ln -s "$work/prefix/bin/echoreg" elsewhere/echoreg
"$work/elsewhere/echoreg" figure boxplot --group A=a.csv --group B=b.csv --out linked.png \
  > linked.out 2> linked.err || fail "echoreg through a symbolic link failed: $(cat linked.err)"
cmp -s box.png linked.png || fail "echoreg through a symbolic link drew other pixels"
echo "renderer module: loaded only by figures, found in the build tree and installed, missing named"
