#include "io/camera/video_decoder.h"

#include <dlfcn.h>

#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace lpstereo::io {
namespace {

constexpr const char* kModuleFile = "liblpstereo_video_decoder.so";

// The places the module is looked for, in order (see the header).
std::vector<std::string> module_candidates() {
  std::vector<std::string> candidates;
  if (const char* file = std::getenv("LPSTEREO_VIDEO_DECODER"); file != nullptr && *file != '\0') candidates.push_back(file);
  std::error_code error;
  const std::filesystem::path executable = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    candidates.push_back((executable.parent_path() / kModuleFile).string());
    candidates.push_back((executable.parent_path().parent_path() / "lib" / "lpstereo" / kModuleFile).string());
  }
#if defined(LPSTEREO_VIDEO_DECODER_BUILD_PATH)
  candidates.push_back(LPSTEREO_VIDEO_DECODER_BUILD_PATH);
#endif
  return candidates;
}

// The module's entry point, loaded once for the process (the handle is never closed: decoders made
// by it may live until exit).
OpenVideoDecoderFunction load_module() {
  static std::once_flag once;
  static OpenVideoDecoderFunction function = nullptr;
  static std::string failure;
  std::call_once(once, [] {
    std::string tried;
    for (const std::string& candidate : module_candidates()) {
      std::error_code error;
      if (!std::filesystem::exists(candidate, error)) {
        tried += (tried.empty() ? "" : ", ") + candidate;
        continue;
      }
      void* handle = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (handle == nullptr) {
        failure = "the video decoder module " + candidate + " cannot be loaded: " + dlerror();
        return;
      }
      function = reinterpret_cast<OpenVideoDecoderFunction>(dlsym(handle, kOpenVideoDecoderSymbol));
      if (function == nullptr) failure = "the video decoder module " + candidate + " has no " + kOpenVideoDecoderSymbol;
      return;
    }
    failure = std::string("video files need the decoder module ") + kModuleFile + " (OpenCV videoio); not found at: " + tried;
  });
  if (function == nullptr) throw std::runtime_error(failure);
  return function;
}

}  // namespace

std::unique_ptr<VideoDecoder> open_video_decoder(const std::string& path) {
  const OpenVideoDecoderFunction open = load_module();
  char error[1024] = {};
  std::unique_ptr<VideoDecoder> decoder(open(path.c_str(), error, sizeof error));
  if (!decoder) throw std::runtime_error(error);
  return decoder;
}

}  // namespace lpstereo::io
