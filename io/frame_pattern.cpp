#include "io/frame_pattern.h"

#include <stdexcept>

namespace lpstereo::io {

FramePattern::FramePattern(const std::string& pattern) : pattern_(pattern) {
  const std::string expected = "'" + pattern + "': expected a file pattern with one frame-number conversion such as %06d or %d, got ";
  int conversions = 0;
  std::string* text = &prefix_;
  for (size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') {
      *text += pattern[i];
      continue;
    }
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      *text += '%';
      ++i;
      continue;
    }
    size_t j = i + 1;
    const bool zero = j < pattern.size() && pattern[j] == '0';
    if (zero) ++j;
    const size_t digits_begin = j;
    while (j < pattern.size() && pattern[j] >= '0' && pattern[j] <= '9' && j - digits_begin < 2) ++j;
    if (j >= pattern.size() || pattern[j] != 'd' || ++conversions > 1) {
      throw std::invalid_argument(expected + (conversions > 1 ? "more than one" : "'" + pattern.substr(i, j + 1 - i) + "'"));
    }
    zero_padded_ = zero;
    width_ = j > digits_begin ? std::stoi(pattern.substr(digits_begin, j - digits_begin)) : 0;
    text = &suffix_;
    i = j;
  }
  if (conversions == 0) throw std::invalid_argument(expected + "none");
}

std::string FramePattern::path(int frame) const {
  std::string number = std::to_string(frame);
  if (static_cast<int>(number.size()) < width_) number.insert(0, static_cast<size_t>(width_) - number.size(), zero_padded_ ? '0' : ' ');
  return prefix_ + number + suffix_;
}

bool FramePattern::has_conversion(const std::string& text) {
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '%') continue;
    if (i + 1 < text.size() && text[i + 1] == '%') {
      ++i;
      continue;
    }
    return true;
  }
  return false;
}

}  // namespace lpstereo::io
