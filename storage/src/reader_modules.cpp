// Loads the reader modules on the first file of their format: Exodus II (exodus_reader.cpp,
// libtetrascope_exodus.so: NetCDF, HDF5, curl, ICU, 54 MB of library files mapped) and CGNS
// (cgns_reader.cpp, libtetrascope_cgns.so: the CGNS library and HDF5). Their libraries are
// mapped only by a process that reads such a file. A module is found at the path its
// environment variable names (TETRASCOPE_EXODUS_MODULE, TETRASCOPE_CGNS_MODULE) when that is
// set, else where the build put it.
#include <dlfcn.h>

#include <cstdlib>
#include <mutex>

#include "format_reader.h"

namespace tetrascope::storage::detail {
namespace {

#if defined(TETRA_EXODUS_MODULE) || defined(TETRA_CGNS_MODULE)
using Make = FormatReader* (*)(const char*, const ReadLimits*, std::string*);

struct ReaderModule {
  const char* format;       // "Exodus II", for messages
  const char* environment;  // the variable that overrides where the module is
  const char* built;        // where the build put it
  const char* symbol;       // its entry point
  std::mutex lock;
  Make make = nullptr;
  std::string load_error;
};

std::unique_ptr<FormatReader> make_through(ReaderModule& module, const std::filesystem::path& path, const ReadLimits& limits) {
  {
    std::lock_guard<std::mutex> hold(module.lock);
    if (!module.make && module.load_error.empty()) {
      const char* chosen = std::getenv(module.environment);
      const std::string file = chosen && *chosen ? chosen : module.built;
      if (void* handle = ::dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL)) {  // kept loaded: readers it made may outlive any call
        module.make = reinterpret_cast<Make>(::dlsym(handle, module.symbol));
        if (!module.make) module.load_error = file + " has no reader";
      } else {
        const char* why = ::dlerror();
        module.load_error = why ? why : file;
      }
    }
  }
  if (!module.make) {
    std::string message = path.string();
    message += ": ";
    message += module.format;
    message += " cannot be read: its module did not load (" + module.load_error + ")";
    throw MeshError(message);
  }
  std::string error;
  FormatReader* reader = module.make(path.c_str(), &limits, &error);
  if (!reader) throw MeshError(error);
  return std::unique_ptr<FormatReader>(reader);
}
#endif

#if !defined(TETRA_EXODUS_MODULE) || !defined(TETRA_CGNS_MODULE)
[[noreturn]] void refuse(const std::filesystem::path& path, const char* format, const char* library) {
  std::string message = path.string();
  message += ": this build of tetrascope reads no ";
  message += format;
  message += " (the ";
  message += library;
  message += " was not found)";
  throw MeshError(message);
}
#endif

}  // namespace

std::unique_ptr<FormatReader> make_exodus_reader(const std::filesystem::path& path, const ReadLimits& limits) {
#ifdef TETRA_EXODUS_MODULE
  static ReaderModule module{"Exodus II", "TETRASCOPE_EXODUS_MODULE", TETRA_EXODUS_MODULE, "tetrascope_make_exodus_reader", {}, nullptr, {}};
  return make_through(module, path, limits);
#else
  (void)limits;
  refuse(path, "Exodus II", "Exodus II library");
#endif
}

std::unique_ptr<FormatReader> make_cgns_reader(const std::filesystem::path& path, const ReadLimits& limits) {
#ifdef TETRA_CGNS_MODULE
  static ReaderModule module{"CGNS", "TETRASCOPE_CGNS_MODULE", TETRA_CGNS_MODULE, "tetrascope_make_cgns_reader", {}, nullptr, {}};
  return make_through(module, path, limits);
#else
  (void)limits;
  refuse(path, "CGNS", "CGNS library");
#endif
}

}  // namespace tetrascope::storage::detail
