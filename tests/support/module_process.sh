# Shared by the module tests that watch a process (render/renderer_module.sh,
# segmentation/dicom_module.sh, filters/mesh_io_module.sh); sourced, not run.
# LD_DEBUG=libs lists every library a process opens, dlopen'd ones included.

fail() { echo "FAIL: $*" >&2; exit 1; }

loads() {  # loads LIBRARY LOGFILE: whether the process logged in LOGFILE opened LIBRARY
  grep -q "calling init: .*/$1" "$2"
}

# never_loaded_by_version_and_detect ECHOREG CAPTURE LIBRARY...: `echoreg --version` and
# `echoreg detect CAPTURE` (its CSV left in detect.csv) open none of the libraries.
never_loaded_by_version_and_detect() {
  _echoreg=$1 _capture=$2
  shift 2
  LD_DEBUG=libs "$_echoreg" --version > version.out 2> version.libs ||
    fail "echoreg --version failed"
  LD_DEBUG=libs "$_echoreg" detect "$_capture" --out detect.csv > detect.out 2> detect.libs ||
    fail "echoreg detect failed: $(grep -v '^ *[0-9]*:' detect.libs)"
  for _log in version.libs detect.libs; do
    for _library in "$@"; do
      if loads "$_library" "$_log"; then fail "${_log%.libs} loaded $_library"; fi
    done
  done
}

# installed_layout ECHOREG: ./prefix/bin/echoreg, a copy of ECHOREG, and an empty
# ./prefix/lib/echoreg; detect runs there without the module and writes detect.csv's bytes.
installed_layout() {
  mkdir -p prefix/bin prefix/lib/echoreg
  cp "$1" prefix/bin/echoreg
  "$PWD/prefix/bin/echoreg" detect "$capture" --out detect-installed.csv > /dev/null 2>&1 ||
    fail "detect needs the module"
  cmp -s detect.csv detect-installed.csv || fail "detect without the module wrote other bytes"
}

# exits_1_naming PATH WHAT ERRFILE COMMAND...: COMMAND fails with exit 1 and its stderr (kept in
# ERRFILE) names PATH, the module it looked for.
exits_1_naming() {
  _path=$1 _what=$2 _err=$3
  shift 3
  _status=0
  "$@" > /dev/null 2> "$_err" || _status=$?
  [ "$_status" -ne 0 ] || fail "$_what succeeded"
  [ "$_status" -eq 1 ] || fail "$_what exited $_status, not 1"
  grep -q "$_path" "$_err" || fail "the error does not name the module's path: $(cat "$_err")"
}

# refused_without_module MODULE OUTPUT: in the installed layout (./prefix, installed_layout) with
# no module, the test's `register` function fails with exit 1, its stderr (register.err) names
# where it looked for MODULE's file, and OUTPUT is not written.
refused_without_module() {
  _status=0
  register "$PWD/prefix/bin/echoreg" || _status=$?
  [ "$_status" -eq 1 ] || fail "register without the module exited $_status, not 1"
  grep -q "$PWD/prefix/lib/echoreg/$(basename "$1")" register.err ||
    fail "the error does not name the module's path: $(cat register.err)"
  [ ! -e "$2" ] || fail "$2 written without the module"
}
