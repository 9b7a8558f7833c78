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
