// A frame file pattern: text with exactly one printf integer conversion, %d or %0<width>d /
// %<width>d (width at most 99; "%%" is a literal %), such as "seq/left_%06d.png". Parsed once, then
// expanded per frame without handing the user's text to printf. `lpstereo obstacles --left/--right`
// and the image-sequence stereo source (io/camera/file_source.h) read their frames through it.
#pragma once

#include <string>

namespace lpstereo::io {

class FramePattern {
 public:
  // Throws std::invalid_argument (one line quoting the pattern) unless it holds exactly one
  // frame-number conversion.
  explicit FramePattern(const std::string& pattern);

  // The file name of frame `frame` (>= 0): the number padded to the conversion's width.
  std::string path(int frame) const;
  const std::string& pattern() const { return pattern_; }

  // True when `text` holds a conversion, valid or not: a '%' that is not part of "%%". (A spec
  // with one is meant as a pattern; the constructor then says what is wrong with it.)
  static bool has_conversion(const std::string& text);

 private:
  std::string pattern_, prefix_, suffix_;
  int width_ = 0;
  bool zero_padded_ = false;
};

}  // namespace lpstereo::io
