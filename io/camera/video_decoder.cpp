#include "io/camera/video_decoder.h"

#include <stdexcept>

#include "io/codec_module.h"

namespace lpstereo::io {

std::unique_ptr<VideoDecoder> open_video_decoder(const std::string& path) {
#if defined(LPSTEREO_VIDEO_DECODER_BUILD_PATH)
  const char* build_path = LPSTEREO_VIDEO_DECODER_BUILD_PATH;
#else
  const char* build_path = nullptr;
#endif
  const CodecModule module{"liblpstereo_video_decoder.so", "LPSTEREO_VIDEO_DECODER", build_path, "video files (OpenCV videoio)"};
  const auto open = reinterpret_cast<OpenVideoDecoderFunction>(codec_module_symbol(module, kOpenVideoDecoderSymbol));
  char error[1024] = {};
  std::unique_ptr<VideoDecoder> decoder(open(path.c_str(), error, sizeof error));
  if (!decoder) throw std::runtime_error(error);
  return decoder;
}

}  // namespace lpstereo::io
