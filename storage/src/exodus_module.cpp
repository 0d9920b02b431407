// Loads the Exodus II reader module (exodus_reader.cpp, libtetrascope_exodus.so) on the first
// Exodus file: its libraries (NetCDF, HDF5, curl, ICU: 54 MB of library files mapped) are
// mapped only by a process that reads Exodus. The module is found at TETRASCOPE_EXODUS_MODULE
// when that is set, else where the build put it.
#include <dlfcn.h>

#include <cstdlib>
#include <mutex>

#include "format_reader.h"

namespace tetrascope::storage::detail {

std::unique_ptr<FormatReader> make_exodus_reader(const std::filesystem::path& path, const ReadLimits& limits) {
#ifdef TETRA_EXODUS_MODULE
  using Make = FormatReader* (*)(const char*, const ReadLimits*, std::string*);
  static std::mutex lock;
  static Make make = nullptr;
  static std::string load_error;
  {
    std::lock_guard<std::mutex> hold(lock);
    if (!make && load_error.empty()) {
      const char* chosen = std::getenv("TETRASCOPE_EXODUS_MODULE");
      const std::string module = chosen && *chosen ? chosen : TETRA_EXODUS_MODULE;
      if (void* handle = ::dlopen(module.c_str(), RTLD_NOW | RTLD_LOCAL)) {  // kept loaded: readers it made may outlive any call
        make = reinterpret_cast<Make>(::dlsym(handle, "tetrascope_make_exodus_reader"));
        if (!make) load_error = module + " has no reader";
      } else {
        const char* why = ::dlerror();
        load_error = why ? why : module;
      }
    }
  }
  if (!make) throw MeshError(path.string() + ": Exodus II cannot be read: its module did not load (" + load_error + ")");
  std::string error;
  FormatReader* reader = make(path.c_str(), &limits, &error);
  if (!reader) throw MeshError(error);
  return std::unique_ptr<FormatReader>(reader);
#else
  (void)limits;
  throw MeshError(path.string() + ": this build of tetrascope reads no Exodus II (the Exodus II library was not found)");
#endif
}

}  // namespace tetrascope::storage::detail
