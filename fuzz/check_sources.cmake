# Every source file the fuzz preset's harnesses compile exists (`cmake -P`, the ctest
# fuzz_preset_sources). Only the fuzz preset reads those lists: a file moved without them breaks
# `make fuzz` and nothing else (sessions 26 and 29 found it so).
#
#   cmake -DFUZZ_LISTS=fuzz/CMakeLists.txt -DSOURCE_DIR=. -P fuzz/check_sources.cmake
file(READ "${FUZZ_LISTS}" text)
string(REGEX MATCHALL "\\$\\{(ECHOREG_CORE_SRC|PROJECT_SOURCE_DIR)\\}/[A-Za-z0-9_./-]+\\.(cpp|cxx)"
  paths "${text}")
list(REMOVE_DUPLICATES paths)
set(missing "")
foreach(path IN LISTS paths)
  string(REPLACE "\${ECHOREG_CORE_SRC}" "${SOURCE_DIR}/core/src" file "${path}")
  string(REPLACE "\${PROJECT_SOURCE_DIR}" "${SOURCE_DIR}" file "${file}")
  if(NOT EXISTS "${file}")
    list(APPEND missing "${path}")
  endif()
endforeach()
list(LENGTH paths count)
if(count EQUAL 0)
  message(FATAL_ERROR "${FUZZ_LISTS}: no source paths found; has the way it names them changed?")
endif()
if(missing)
  string(REPLACE ";" "\n  " missing "${missing}")
  message(FATAL_ERROR "${FUZZ_LISTS} names source files that do not exist (the fuzz preset will "
    "not configure):\n  ${missing}")
endif()
message(STATUS "${FUZZ_LISTS}: ${count} source files, all present")
