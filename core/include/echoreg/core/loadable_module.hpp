// Shared libraries echoreg opens with dlopen only when a command needs them (the renderer module,
// the DICOM module): libraries whose load costs every process start-up time (OSMesa's LLVM,
// GDCM's dictionaries) stay out of the commands that never use them (docs/architecture.md,
// "Modules opened on demand"). Every module lies in EXE_DIR/../lib/echoreg/ and exports a C
// function returning its ABI string, which must equal the executable's.
#pragma once

#include <exception>
#include <filesystem>
#include <string>

namespace echoreg::core {

/// What a caller knows of the module it opens, for the checks and the messages.
struct ModuleIdentity {
  /// In messages: "renderer module", "DICOM module".
  std::string name;
  /// The CMake target that builds it, for the hint in messages.
  std::string target;
  /// What the module does for echoreg, for the hint ("draws figures", "reads and writes DICOM").
  std::string purpose;
  /// The C function `const char* ABI_SYMBOL()` the module exports.
  std::string abiSymbol;
  /// What that function must return: the version, the compiler and the layout of the types that
  /// cross, as this executable was built.
  std::string abi;
};

/// EXE_DIR/../lib/echoreg/`fileName`, EXE_DIR being the folder of the running executable
/// (/proc/self/exe: a symbolic link to the executable is followed to the file itself). In the build
/// tree build/release/cli/echoreg (and the tests and benchmarks beside it) finds
/// build/release/lib/echoreg/; installed, PREFIX/bin/echoreg finds PREFIX/lib/echoreg/. Throws
/// std::runtime_error when /proc/self/exe cannot be read.
std::filesystem::path moduleBesideExecutable(const std::string& fileName);

/// Opens the module at `path` with RTLD_NOW | RTLD_LOCAL (its libraries form their own lookup
/// scope) once per process and path, keeps it open (VTK and GDCM keep objects of their libraries
/// until exit), checks that identity.abiSymbol returns identity.abi, and returns the address of
/// `symbol`. Throws FileError naming `path` when it cannot be opened, is not the module (a symbol
/// missing) or is the module of another build. Thread-safe.
void* moduleSymbol(const std::filesystem::path& path, const ModuleIdentity& identity,
                   const char* symbol);

/// The entry point `symbol` of the module `fileName` beside the executable (moduleBesideExecutable,
/// moduleSymbol), as the function pointer type `Function`.
template <typename Function>
Function moduleFunction(const std::string& fileName, const ModuleIdentity& identity,
                        const char* symbol) {
  return reinterpret_cast<Function>(
      moduleSymbol(moduleBesideExecutable(fileName), identity, symbol));
}

/// Runs `work` inside a module's C entry point: whatever it throws is caught into `*error` (an
/// exception must not unwind through a C function), for the caller to rethrow.
template <typename Work>
void captureException(std::exception_ptr* error, Work&& work) {
  try {
    work();
  } catch (...) {
    *error = std::current_exception();
  }
}

/// Rethrows what a module's entry point caught (captureException), if anything: the same object,
/// so the same type and message as if the work had run in the caller.
inline void rethrowFromModule(const std::exception_ptr& error) {
  if (error)
    std::rethrow_exception(error);
}

}  // namespace echoreg::core
