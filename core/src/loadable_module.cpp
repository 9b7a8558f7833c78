#include "echoreg/core/loadable_module.hpp"

#include "echoreg/core/error.hpp"

#include <dlfcn.h>

#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <system_error>
#include <utility>

#ifndef ECHOREG_MODULE_DIR
#error "ECHOREG_MODULE_DIR must be defined (core/CMakeLists.txt)"
#endif

namespace echoreg::core {

namespace {

std::string lastDlError() {
  const char* message = dlerror();
  return message != nullptr ? message : "unknown error";
}

std::string hintFor(const ModuleIdentity& identity) {
  return "; echoreg " + identity.purpose + " through this module, built with it (CMake target " +
         identity.target + ") into lib/echoreg beside the folder of the executable";
}

}  // namespace

std::filesystem::path moduleBesideExecutable(const std::string& fileName) {
  std::error_code error;
  const std::filesystem::path executable = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) {
    throw std::runtime_error("cannot find " + fileName + ": /proc/self/exe unreadable (" +
                             error.message() + ")");
  }
  return (executable.parent_path() / ".." / ECHOREG_MODULE_DIR / fileName).lexically_normal();
}

void* moduleSymbol(const std::filesystem::path& path, const ModuleIdentity& identity,
                   const char* symbol) {
  static std::mutex mutex;
  // (path, ABI) -> the handle whose ABI was checked.
  static std::map<std::pair<std::string, std::string>, void*> opened;
  const std::lock_guard<std::mutex> lock(mutex);
  const std::pair<std::string, std::string> key{path.string(), identity.abi};
  void* handle = nullptr;
  if (const auto it = opened.find(key); it != opened.end()) {
    handle = it->second;
  } else {
    handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      throw FileError(path.string(), "cannot open the " + identity.name + " (" + lastDlError() +
                                         ")" + hintFor(identity));
    }
    using AbiFunction = const char* (*)();
    auto abi = reinterpret_cast<AbiFunction>(dlsym(handle, identity.abiSymbol.c_str()));
    if (abi == nullptr) {
      throw FileError(path.string(), "is not echoreg's " + identity.name + " (no " +
                                         identity.abiSymbol + ")" + hintFor(identity));
    }
    const std::string theirs = abi();
    if (theirs != identity.abi) {
      throw FileError(path.string(), "is the " + identity.name + " of another build (" + theirs +
                                         ", this echoreg: " + identity.abi + ")" +
                                         hintFor(identity));
    }
    opened.emplace(key, handle);
  }
  void* address = dlsym(handle, symbol);
  if (address == nullptr) {
    throw FileError(path.string(), "is not echoreg's " + identity.name + " (no " +
                                       std::string(symbol) + ")" + hintFor(identity));
  }
  return address;
}

}  // namespace echoreg::core
