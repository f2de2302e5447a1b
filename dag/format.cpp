#include "dag/format.h"

#include <array>
#include <charconv>

namespace lpstereo {

namespace {
struct TypeInfo {
  ElementType type;
  std::string_view name;
  int bytes;
};
constexpr std::array<TypeInfo, 9> kTypes = {{
    {ElementType::u8, "u8", 1},
    {ElementType::u16, "u16", 2},
    {ElementType::s16, "s16", 2},
    {ElementType::u32, "u32", 4},
    {ElementType::s32, "s32", 4},
    {ElementType::census32, "census32", 4},
    {ElementType::census64, "census64", 8},
    {ElementType::remap_q5, "remap_q5", 4},
    {ElementType::bytes, "bytes", 1},
}};
bool has_q_format(ElementType type) { return type == ElementType::s16 || type == ElementType::s32; }
}  // namespace

int element_bytes(ElementType type) {
  for (const TypeInfo& info : kTypes) {
    if (info.type == type) return info.bytes;
  }
  return 0;
}

std::string_view element_type_name(ElementType type) {
  for (const TypeInfo& info : kTypes) {
    if (info.type == type) return info.name;
  }
  return "unknown";
}

std::optional<ElementType> parse_element_type(std::string_view name) {
  for (const TypeInfo& info : kTypes) {
    if (info.name == name) return info.type;
  }
  return std::nullopt;
}

std::string format_name(const BufferFormat& format) {
  std::string name(element_type_name(format.type));
  if (has_q_format(format.type)) name += "q" + std::to_string(format.fraction_bits);
  return name;
}

std::optional<BufferFormat> parse_format(std::string_view name) {
  for (const TypeInfo& info : kTypes) {
    if (!has_q_format(info.type)) {
      if (info.name == name) return BufferFormat{info.type, 0};
      continue;
    }
    // s16 alone means Q0; s16qN means N fraction bits.
    if (name.substr(0, info.name.size()) != info.name) continue;
    std::string_view rest = name.substr(info.name.size());
    if (rest.empty()) return BufferFormat{info.type, 0};
    if (rest[0] != 'q') continue;
    int fraction_bits = -1;
    auto [end, error] = std::from_chars(rest.data() + 1, rest.data() + rest.size(), fraction_bits);
    const int max_bits = 8 * info.bytes - 1;
    if (error == std::errc() && end == rest.data() + rest.size() && fraction_bits >= 0 && fraction_bits <= max_bits) {
      return BufferFormat{info.type, fraction_bits};
    }
  }
  return std::nullopt;
}

}  // namespace lpstereo
