// OpenCV's codec libraries as modules loaded on first use. imgcodecs and videoio each pull in
// dozens of shared libraries (GDAL, GDCM, Poppler, FFmpeg, GStreamer, ...), which every lpstereo
// process paid for at start-up, PNG pair or not. The code that needs them is built as a module of
// its own (a MODULE library exporting one extern "C" entry point per call) and dlopen'ed the first
// time a file needs it, from (the first that exists): the file named by the module's environment
// variable, the executable's folder, <executable>/../lib/lpstereo/, and the build tree it was
// built in.
#pragma once

#include <string>

namespace lpstereo::io {

struct CodecModule {
  const char* file;                  // e.g. "liblpstereo_video_decoder.so"
  const char* environment_variable;  // names the module file, overriding the search
  const char* build_path;            // the build tree's copy (the last place looked), or nullptr
  const char* needed_for;            // what needs it, for the error: "video files"
};

// The address of `symbol` in the module, loaded once for the process (never closed: objects made by
// it may live until exit). Throws std::runtime_error naming the module and the places tried, or
// dlopen's reason, or the missing symbol.
void* codec_module_symbol(const CodecModule& module, const char* symbol);

}  // namespace lpstereo::io
