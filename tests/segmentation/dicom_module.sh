#!/bin/sh
# The DICOM module as a process sees it (dicom/dicom_module_abi.hpp): commands that read no DICOM
# never load GDCM (LD_DEBUG=libs lists every library a process opens, dlopen'd ones included); a
# CT read opens the module from EXE_DIR/../lib/echoreg, which is also where an installation puts
# it; without the module, or with a file that is not it, reading a CT fails with exit 1 and an
# error naming the path it looked at, while the other commands still run.
# Usage: dicom_module.sh ECHOREG MODULE CAPTURE SERIES WORKDIR
set -eu
echoreg=$1 module=$2 capture=$3 series=$4 work=$5
. "$(dirname "$0")/../support/module_process.sh"

rm -rf "$work" && mkdir -p "$work" && cd "$work"

# Commands that read no DICOM.
never_loaded_by_version_and_detect "$echoreg" "$capture" libgdcmMSFF libgdcmDSED libgdcmCommon \
  libechoreg_dicom

# Reading a CT loads the module, and GDCM with it.
LD_DEBUG=libs "$echoreg" info "$series" --json > info.json 2> info.libs ||
  fail "info on the CT failed: $(grep -v '^ *[0-9]*:' info.libs)"
loads libechoreg_dicom info.libs || fail "info on the CT did not load the module"
loads libgdcmMSFF info.libs || fail "info on the CT did not load GDCM"
grep -q '"series_instance_uid"' info.json || fail "info on the CT printed no series: $(cat info.json)"

# The installed layout: PREFIX/bin/echoreg finds PREFIX/lib/echoreg/ and reads the same series.
installed_layout "$echoreg"
installed="$work/prefix/lib/echoreg/$(basename "$module")"
exits_1_naming "$installed" "info on the CT without the module" missing.err \
  "$work/prefix/bin/echoreg" info "$series" --json
# A file in its place that is not the module.
echo "not a shared object" > "$installed"
exits_1_naming "$installed" "info on the CT with a text file as the module" foreign.err \
  "$work/prefix/bin/echoreg" info "$series" --json
cp "$module" prefix/lib/echoreg/
"$work/prefix/bin/echoreg" info "$series" --json > installed.json 2> installed.err ||
  fail "the installed layout failed: $(cat installed.err)"
cmp -s info.json installed.json || fail "the installed layout read the series otherwise"
echo "DICOM module: loaded only to read a CT, found in the build tree and installed, missing named"
