// A small PLY reader for the tests: vertex elements with float x, y, z and uchar red, green, blue in
// that order (what arm::write_ply writes), ascii or binary_little_endian. Written from the format's
// description (Turk, "The PLY Polygon File Format"), independently of the writer, so a round trip
// checks the writer's header and layout rather than echoing it.
#pragma once

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lpstereo::testing {

struct PlyVertex {
  float x = 0, y = 0, z = 0;
  int red = 0, green = 0, blue = 0;
};

struct PlyFile {
  std::string format;  // "ascii" or "binary_little_endian"
  std::vector<std::string> comments;
  std::vector<std::string> properties;  // "float x", ...
  std::vector<PlyVertex> vertices;
};

inline PlyFile read_ply(const std::string& path) {
  std::ifstream stream(path, std::ios::binary);
  if (!stream) throw std::runtime_error(path + ": cannot open");
  const std::string bytes((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
  const size_t header_end = bytes.find("end_header\n");
  if (bytes.rfind("ply\n", 0) != 0 || header_end == std::string::npos) throw std::runtime_error(path + ": not a PLY file");
  PlyFile file;
  size_t vertex_count = 0;
  std::istringstream header(bytes.substr(0, header_end));
  std::string line;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      words >> file.format;
    } else if (keyword == "comment") {
      file.comments.push_back(line.substr(8));
    } else if (keyword == "element") {
      std::string name;
      words >> name >> vertex_count;
      if (name != "vertex") throw std::runtime_error(path + ": unexpected element " + name);
    } else if (keyword == "property") {
      file.properties.push_back(line.substr(9));
    }
  }
  const std::vector<std::string> expected = {"float x", "float y", "float z", "uchar red", "uchar green", "uchar blue"};
  if (file.properties != expected) throw std::runtime_error(path + ": unexpected vertex properties");
  const size_t body = header_end + std::strlen("end_header\n");
  if (file.format == "ascii") {
    std::istringstream values(bytes.substr(body));
    for (size_t i = 0; i < vertex_count; ++i) {
      PlyVertex vertex;
      if (!(values >> vertex.x >> vertex.y >> vertex.z >> vertex.red >> vertex.green >> vertex.blue)) {
        throw std::runtime_error(path + ": vertex " + std::to_string(i) + " unreadable");
      }
      file.vertices.push_back(vertex);
    }
    std::string rest;
    if (values >> rest) throw std::runtime_error(path + ": data after the last vertex");
  } else if (file.format == "binary_little_endian") {
    if (bytes.size() != body + vertex_count * 15) {
      throw std::runtime_error(path + ": expected " + std::to_string(body + vertex_count * 15) + " bytes, got " +
                               std::to_string(bytes.size()));
    }
    auto float_at = [&](size_t offset) {
      uint32_t bits = 0;
      for (int i = 3; i >= 0; --i) bits = bits << 8 | static_cast<uint8_t>(bytes[offset + static_cast<size_t>(i)]);
      float value;
      std::memcpy(&value, &bits, 4);
      return value;
    };
    for (size_t i = 0; i < vertex_count; ++i) {
      const size_t offset = body + i * 15;
      file.vertices.push_back({float_at(offset), float_at(offset + 4), float_at(offset + 8),
                               static_cast<uint8_t>(bytes[offset + 12]), static_cast<uint8_t>(bytes[offset + 13]),
                               static_cast<uint8_t>(bytes[offset + 14])});
    }
  } else {
    throw std::runtime_error(path + ": unsupported format " + file.format);
  }
  return file;
}

}  // namespace lpstereo::testing
