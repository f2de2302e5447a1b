#include "io/codec_module.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace lpstereo::io {
namespace {

// The places a module is looked for, in order (see the header).
std::vector<std::string> module_candidates(const CodecModule& module) {
  std::vector<std::string> candidates;
  if (const char* file = std::getenv(module.environment_variable); file != nullptr && *file != '\0') candidates.push_back(file);
  std::error_code error;
  const std::filesystem::path executable = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    candidates.push_back((executable.parent_path() / module.file).string());
    candidates.push_back((executable.parent_path().parent_path() / "lib" / "lpstereo" / module.file).string());
  }
  if (module.build_path != nullptr) candidates.push_back(module.build_path);
  return candidates;
}

// A loaded module's handle, or why it could not be loaded.
struct Loaded {
  void* handle = nullptr;
  std::string failure;
};

Loaded load(const CodecModule& module) {
  Loaded loaded;
  std::string tried;
  for (const std::string& candidate : module_candidates(module)) {
    std::error_code error;
    if (!std::filesystem::exists(candidate, error)) {
      tried += (tried.empty() ? "" : ", ") + candidate;
      continue;
    }
    loaded.handle = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (loaded.handle == nullptr) loaded.failure = "the module " + candidate + " cannot be loaded: " + dlerror();
    return loaded;
  }
  loaded.failure = std::string(module.needed_for) + " need the module " + module.file + "; not found at: " + tried;
  return loaded;
}

}  // namespace

void* codec_module_symbol(const CodecModule& module, const char* symbol) {
  static std::mutex mutex;
  static std::map<std::string, Loaded> modules;  // by file name
  const std::lock_guard<std::mutex> lock(mutex);
  auto found = modules.find(module.file);
  if (found == modules.end()) found = modules.emplace(module.file, load(module)).first;
  const Loaded& loaded = found->second;
  if (loaded.handle == nullptr) throw std::runtime_error(loaded.failure);
  void* address = dlsym(loaded.handle, symbol);
  if (address == nullptr) throw std::runtime_error(std::string("the module ") + module.file + " has no " + symbol);
  return address;
}

}  // namespace lpstereo::io
