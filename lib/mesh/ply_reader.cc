#include "mesh/ply_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <sstream>
#include <tuple>
#include <utility>

#include <Eigen/Geometry>

#include "core/error.h"

namespace g6d {
namespace {

// What to do about a file whose body does not match its header.
constexpr const char* kReexportHint =
    "the file is truncated or corrupt, or its header does not match its data: re-export the "
    "mesh (or copy it again)";

enum class Type { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

// Both the names of the PLY specification and the sized ones many writers use.
bool ParseType(const std::string& name, Type* type) {
  static const std::map<std::string, Type> kTypes = {
      {"char", Type::kInt8},     {"int8", Type::kInt8},       {"uchar", Type::kUint8},
      {"uint8", Type::kUint8},   {"short", Type::kInt16},     {"int16", Type::kInt16},
      {"ushort", Type::kUint16}, {"uint16", Type::kUint16},   {"int", Type::kInt32},
      {"int32", Type::kInt32},   {"uint", Type::kUint32},     {"uint32", Type::kUint32},
      {"float", Type::kFloat32}, {"float32", Type::kFloat32}, {"double", Type::kFloat64},
      {"float64", Type::kFloat64}};
  const auto found = kTypes.find(name);
  if (found == kTypes.end()) return false;
  *type = found->second;
  return true;
}

int TypeSize(Type type) {
  switch (type) {
    case Type::kInt8:
    case Type::kUint8:
      return 1;
    case Type::kInt16:
    case Type::kUint16:
      return 2;
    case Type::kInt32:
    case Type::kUint32:
    case Type::kFloat32:
      return 4;
    case Type::kFloat64:
      return 8;
  }
  return 0;
}

// Largest value of an integer type (a colour's full intensity); 1 for floating types.
double ColorScale(Type type) {
  switch (type) {
    case Type::kInt8:
      return 127.0;
    case Type::kUint8:
      return 255.0;
    case Type::kInt16:
      return 32767.0;
    case Type::kUint16:
      return 65535.0;
    case Type::kInt32:
      return 2147483647.0;
    case Type::kUint32:
      return 4294967295.0;
    case Type::kFloat32:
    case Type::kFloat64:
      return 1.0;
  }
  return 1.0;
}

struct Property {
  std::string name;
  Type type = Type::kFloat32;  // of the value, or of a list's items
  bool is_list = false;
  Type count_type = Type::kUint8;  // of a list's length
};

struct Element {
  std::string name;
  int64_t count = 0;
  std::vector<Property> properties;
};

std::vector<std::string> SplitWords(const std::string& line) {
  std::istringstream stream(line);
  return {std::istream_iterator<std::string>(stream), std::istream_iterator<std::string>()};
}

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

bool IsLittleEndianHost() {
  const uint16_t probe = 1;
  unsigned char first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

// Reads the values of a PLY body one at a time, in either encoding.
class BodyReader {
 public:
  BodyReader(const std::string& data, size_t offset, PlyFormat format)
      : data_(data), offset_(offset), format_(format) {
    swap_ = format != PlyFormat::kAscii &&
            (format == PlyFormat::kBinaryLittleEndian) != IsLittleEndianHost();
  }

  // Reads one value of `type` into `value`; false when the data ended or (ASCII) the next
  // word is not a number.
  bool Read(Type type, double* value) {
    if (format_ == PlyFormat::kAscii) return ReadText(value);
    const size_t size = static_cast<size_t>(TypeSize(type));
    if (data_.size() - offset_ < size) return false;
    unsigned char bytes[8];
    std::memcpy(bytes, data_.data() + offset_, size);
    if (swap_) std::reverse(bytes, bytes + size);
    offset_ += size;
    *value = Decode(type, bytes);
    return true;
  }

  bool AtEnd() const { return offset_ >= data_.size(); }
  // 1-based line of the next value (ASCII bodies).
  int64_t line() const { return line_; }
  // The next word of an ASCII body, for messages.
  std::string NextWord() const {
    size_t end = offset_;
    while (end < data_.size() && !std::isspace(static_cast<unsigned char>(data_[end]))) ++end;
    return data_.substr(offset_, std::min<size_t>(end - offset_, 40));
  }
  // Bytes after the last value that are not white space.
  size_t TrailingNonSpaceBytes() const {
    size_t count = 0;
    for (size_t i = offset_; i < data_.size(); ++i) {
      if (!std::isspace(static_cast<unsigned char>(data_[i]))) ++count;
    }
    return count;
  }
  size_t RemainingBytes() const { return data_.size() - offset_; }

  void set_first_line(int64_t line) { line_ = line; }

 private:
  static double Decode(Type type, const unsigned char* bytes) {
    switch (type) {
      case Type::kInt8:
        return Cast<int8_t>(bytes);
      case Type::kUint8:
        return Cast<uint8_t>(bytes);
      case Type::kInt16:
        return Cast<int16_t>(bytes);
      case Type::kUint16:
        return Cast<uint16_t>(bytes);
      case Type::kInt32:
        return Cast<int32_t>(bytes);
      case Type::kUint32:
        return Cast<uint32_t>(bytes);
      case Type::kFloat32:
        return Cast<float>(bytes);
      case Type::kFloat64:
        return Cast<double>(bytes);
    }
    return 0.0;
  }

  template <typename T>
  static double Cast(const unsigned char* bytes) {
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return static_cast<double>(value);
  }

  bool ReadText(double* value) {
    while (offset_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[offset_]))) {
      if (data_[offset_] == '\n') ++line_;
      ++offset_;
    }
    if (offset_ >= data_.size()) return false;
    // The file's bytes are held in a std::string, so strtod stops at its terminating null.
    const char* begin = data_.c_str() + offset_;
    char* end = nullptr;
    *value = std::strtod(begin, &end);
    if (end == begin || (*end != '\0' && !std::isspace(static_cast<unsigned char>(*end)))) {
      return false;
    }
    offset_ += static_cast<size_t>(end - begin);
    return true;
  }

  const std::string& data_;
  size_t offset_ = 0;
  PlyFormat format_;
  bool swap_ = false;
  int64_t line_ = 1;
};

// Where each vertex value goes, by property name (as assimp and most writers name them).
enum class VertexRole { kNone, kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kU, kV };

VertexRole RoleOf(const std::string& name) {
  static const std::map<std::string, VertexRole> kRoles = {
      {"x", VertexRole::kX},          {"y", VertexRole::kY},
      {"z", VertexRole::kZ},          {"nx", VertexRole::kNx},
      {"ny", VertexRole::kNy},        {"nz", VertexRole::kNz},
      {"red", VertexRole::kRed},      {"green", VertexRole::kGreen},
      {"blue", VertexRole::kBlue},    {"r", VertexRole::kRed},
      {"g", VertexRole::kGreen},      {"b", VertexRole::kBlue},
      {"diffuse_red", VertexRole::kRed},
      {"diffuse_green", VertexRole::kGreen},
      {"diffuse_blue", VertexRole::kBlue},
      {"u", VertexRole::kU},          {"v", VertexRole::kV},
      {"s", VertexRole::kU},          {"t", VertexRole::kV},
      {"texture_u", VertexRole::kU},  {"texture_v", VertexRole::kV},
      {"texture_s", VertexRole::kU},  {"texture_t", VertexRole::kV}};
  const auto found = kRoles.find(name);
  return found == kRoles.end() ? VertexRole::kNone : found->second;
}

// Parsed header: its elements, the body's encoding and where the body starts.
struct Header {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<Element> elements;
  std::string texture_file;
  size_t body_offset = 0;
  int64_t body_first_line = 1;
};

Header ParseHeader(const std::string& data, const std::string& path) {
  const std::string where = "ReadPly: '" + path + "': ";
  Header header;
  bool have_format = false;
  size_t offset = 0;
  int64_t line_number = 0;
  while (true) {
    const size_t newline = data.find('\n', offset);
    if (newline == std::string::npos) {
      G6D_THROW(where << "the header has no 'end_header' line; " << kReexportHint);
    }
    std::string line = data.substr(offset, newline - offset);
    if (!line.empty() && line.back() == '\r') line.pop_back();  // CR LF line ends
    offset = newline + 1;
    ++line_number;
    const std::vector<std::string> words = SplitWords(line);
    if (line_number == 1) {
      if (words.size() != 1 || Lower(words[0]) != "ply") {
        G6D_THROW(where << "does not start with the 'ply' magic line (not a PLY file?)");
      }
      continue;
    }
    if (words.empty()) continue;
    const std::string& keyword = words[0];
    const auto bad_line = [&](const std::string& what) {
      G6D_THROW(where << "header line " << line_number << " '" << line << "': " << what
                      << "; " << kReexportHint);
    };
    if (keyword == "end_header") {
      header.body_offset = offset;
      header.body_first_line = line_number + 1;
      break;
    } else if (keyword == "format") {
      if (words.size() < 2) bad_line("no format");
      if (words[1] == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (words[1] == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittleEndian;
      } else if (words[1] == "binary_big_endian") {
        header.format = PlyFormat::kBinaryBigEndian;
      } else {
        bad_line("unknown format '" + words[1] +
                 "' (expected ascii, binary_little_endian or binary_big_endian)");
      }
      have_format = true;
    } else if (keyword == "comment") {
      // `comment TextureFile name.png`: the texture image (MeshLab, BOP); the name may
      // hold spaces, so it is the rest of the line.
      if (words.size() >= 3 && Lower(words[1]) == "texturefile") {
        const size_t start = line.find(words[1]) + words[1].size();
        std::string name = line.substr(start);
        name.erase(0, name.find_first_not_of(" \t"));
        name.erase(name.find_last_not_of(" \t") + 1);
        header.texture_file = name;
      }
    } else if (keyword == "obj_info") {
      // Free text.
    } else if (keyword == "element") {
      if (words.size() != 3) bad_line("expected 'element <name> <count>'");
      char* end = nullptr;
      const long long count = std::strtoll(words[2].c_str(), &end, 10);
      if (*end != '\0' || count < 0) bad_line("the count is not a number >= 0");
      header.elements.push_back({words[1], static_cast<int64_t>(count), {}});
    } else if (keyword == "property") {
      if (header.elements.empty()) bad_line("a property before any element");
      Property property;
      if (words.size() == 5 && words[1] == "list") {
        property.is_list = true;
        if (!ParseType(words[2], &property.count_type) || !ParseType(words[3], &property.type)) {
          bad_line("unknown type");
        }
        if (property.count_type == Type::kFloat32 || property.count_type == Type::kFloat64) {
          bad_line("a list's count type must be an integer type");
        }
        property.name = words[4];
      } else if (words.size() == 3) {
        if (!ParseType(words[1], &property.type)) bad_line("unknown type '" + words[1] + "'");
        property.name = words[2];
      } else {
        bad_line("expected 'property <type> <name>' or 'property list <type> <type> <name>'");
      }
      header.elements.back().properties.push_back(property);
    } else {
      bad_line("unknown keyword '" + keyword + "'");
    }
  }
  if (!have_format) G6D_THROW(where << "the header has no 'format' line; " << kReexportHint);
  return header;
}

// One polygon of the face element: its corners and, when the file has them, a texture
// coordinate per corner.
struct Polygon {
  std::vector<int64_t> corners;
  std::vector<Eigen::Vector2f> corner_uvs;  // empty or one per corner
};

// Splits a polygon into triangles: a fan from its reflex corner when it has one (then
// every diagonal lies inside for a quad), else from its first corner (exact for convex
// polygons). Polygons with more than 4 corners and several reflex corners are rare in CAD
// meshes; they keep the fan, as a simple polygon of more corners is not always a fan.
void Triangulate(const std::vector<int>& corners, const std::vector<Eigen::Vector3d>& positions,
                 std::vector<Eigen::Vector3i>* triangles) {
  const int n = static_cast<int>(corners.size());
  int start = 0;
  if (n > 3) {
    // Newell's normal of the polygon.
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    for (int i = 0; i < n; ++i) {
      normal += positions[corners[i]].cross(positions[corners[(i + 1) % n]]);
    }
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d& previous = positions[corners[(i + n - 1) % n]];
      const Eigen::Vector3d& here = positions[corners[i]];
      const Eigen::Vector3d& next = positions[corners[(i + 1) % n]];
      if ((here - previous).cross(next - here).dot(normal) < 0.0) {
        start = i;
        break;
      }
    }
  }
  for (int k = 1; k + 1 < n; ++k) {
    triangles->emplace_back(corners[start], corners[(start + k) % n], corners[(start + k + 1) % n]);
  }
}

}  // namespace

bool IsPlyFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char start[5] = {};
  in.read(start, sizeof(start));
  const std::string magic = Lower(std::string(start, static_cast<size_t>(in.gcount())));
  return magic.rfind("ply\n", 0) == 0 || magic.rfind("ply\r\n", 0) == 0;
}

PlyMesh ReadPly(const std::string& path) {
  const std::string where = "ReadPly: '" + path + "': ";
  std::string data;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) G6D_THROW(where << "cannot be opened");
    data.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const Header header = ParseHeader(data, path);

  PlyMesh mesh;
  mesh.format = header.format;
  mesh.texture_file = header.texture_file;
  const Element* vertex_element = nullptr;
  for (const Element& element : header.elements) {
    if (element.name == "vertex") {
      if (vertex_element != nullptr) G6D_THROW(where << "has two vertex elements");
      vertex_element = &element;
    }
    if (element.name == "face") mesh.header_faces += element.count;
  }
  if (vertex_element == nullptr) G6D_THROW(where << "has no vertex element (not a mesh?)");
  mesh.header_vertices = vertex_element->count;

  // What the vertex element holds.
  bool has_role[12] = {};
  for (const Property& property : vertex_element->properties) {
    if (!property.is_list) has_role[static_cast<int>(RoleOf(property.name))] = true;
  }
  const auto has = [&](VertexRole role) { return has_role[static_cast<int>(role)]; };
  if (!has(VertexRole::kX) || !has(VertexRole::kY) || !has(VertexRole::kZ)) {
    G6D_THROW(where << "the vertex element has no x, y and z properties (not a mesh?)");
  }
  const bool has_normals = has(VertexRole::kNx) && has(VertexRole::kNy) && has(VertexRole::kNz);
  const bool has_colors =
      has(VertexRole::kRed) && has(VertexRole::kGreen) && has(VertexRole::kBlue);
  const bool has_uvs = has(VertexRole::kU) && has(VertexRole::kV);
  // Counts come from the file: reserve no more than its size could hold (a byte a value).
  const size_t reserve_limit = data.size();
  const size_t num_vertices = static_cast<size_t>(vertex_element->count);
  if (num_vertices > reserve_limit) {
    G6D_THROW(where << "the header declares " << num_vertices << " vertices but the file has only "
                    << data.size() << " bytes; " << kReexportHint);
  }
  mesh.positions.resize(num_vertices);
  if (has_normals) mesh.normals.resize(num_vertices);
  if (has_colors) mesh.colors.resize(num_vertices);
  if (has_uvs) mesh.uvs.resize(num_vertices);

  BodyReader reader(data, header.body_offset, header.format);
  reader.set_first_line(header.body_first_line);
  std::vector<Polygon> polygons;
  bool any_corner_uvs = false;
  std::vector<VertexRole> vertex_roles;
  for (const Property& property : vertex_element->properties) {
    vertex_roles.push_back(RoleOf(property.name));
  }
  for (const Element& element : header.elements) {
    const bool is_vertex = &element == vertex_element;
    const bool is_face = element.name == "face";
    if (is_face) polygons.reserve(std::min<size_t>(static_cast<size_t>(element.count), reserve_limit));
    for (int64_t item = 0; item < element.count; ++item) {
      Polygon polygon;
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        const auto fail = [&]() {
          std::ostringstream message;
          message << where;
          if (reader.AtEnd()) {
            message << "the data ends in " << element.name << " " << item << " of "
                    << element.count << " (property '" << property.name << "')";
          } else {
            message << "line " << reader.line() << ": '" << reader.NextWord()
                    << "' is not a number (" << element.name << " " << item << ", property '"
                    << property.name << "')";
          }
          message << "; " << kReexportHint;
          throw Error(message.str());
        };
        double value = 0.0;
        if (!property.is_list) {
          if (!reader.Read(property.type, &value)) fail();
          if (!is_vertex) continue;
          const size_t v = static_cast<size_t>(item);
          const double scale = ColorScale(property.type);
          switch (vertex_roles[p]) {
            case VertexRole::kX:
              mesh.positions[v].x() = value;
              break;
            case VertexRole::kY:
              mesh.positions[v].y() = value;
              break;
            case VertexRole::kZ:
              mesh.positions[v].z() = value;
              break;
            case VertexRole::kNx:
              if (has_normals) mesh.normals[v].x() = static_cast<float>(value);
              break;
            case VertexRole::kNy:
              if (has_normals) mesh.normals[v].y() = static_cast<float>(value);
              break;
            case VertexRole::kNz:
              if (has_normals) mesh.normals[v].z() = static_cast<float>(value);
              break;
            case VertexRole::kRed:
              if (has_colors) mesh.colors[v].x() = static_cast<float>(value / scale);
              break;
            case VertexRole::kGreen:
              if (has_colors) mesh.colors[v].y() = static_cast<float>(value / scale);
              break;
            case VertexRole::kBlue:
              if (has_colors) mesh.colors[v].z() = static_cast<float>(value / scale);
              break;
            case VertexRole::kU:
              if (has_uvs) mesh.uvs[v].x() = static_cast<float>(value);
              break;
            case VertexRole::kV:
              if (has_uvs) mesh.uvs[v].y() = static_cast<float>(value);
              break;
            case VertexRole::kNone:
              break;
          }
          continue;
        }
        if (!reader.Read(property.count_type, &value)) fail();
        if (!(value >= 0.0)) {
          G6D_THROW(where << element.name << " " << item << ": list '" << property.name
                          << "' has length " << value << "; " << kReexportHint);
        }
        if (value > static_cast<double>(reader.RemainingBytes())) {  // every value takes a byte
          G6D_THROW(where << "the data ends in " << element.name << " " << item << " of "
                          << element.count << " (property '" << property.name
                          << "', a list of " << value << "); " << kReexportHint);
        }
        const int64_t length = static_cast<int64_t>(value);
        const bool indices = is_face && (property.name == "vertex_indices" ||
                                         property.name == "vertex_index");
        const bool corner_uvs = is_face && property.name == "texcoord";
        std::vector<double> values;
        values.reserve(static_cast<size_t>(length));
        for (int64_t i = 0; i < length; ++i) {
          if (!reader.Read(property.type, &value)) fail();
          if (indices || corner_uvs) values.push_back(value);
        }
        if (indices) {
          for (double index : values) {
            if (!(index >= 0.0 && index < static_cast<double>(num_vertices))) {
              G6D_THROW(where << "face " << item << " refers to vertex " << index
                              << " but the file has " << num_vertices << " vertices; "
                              << kReexportHint);
            }
            polygon.corners.push_back(static_cast<int64_t>(index));
          }
        } else if (corner_uvs && !values.empty()) {
          for (size_t i = 0; i + 1 < values.size(); i += 2) {
            polygon.corner_uvs.emplace_back(static_cast<float>(values[i]),
                                            static_cast<float>(values[i + 1]));
          }
        }
      }
      if (!is_face) continue;
      if (!polygon.corner_uvs.empty() && polygon.corner_uvs.size() != polygon.corners.size()) {
        G6D_THROW(where << "face " << item << " has " << polygon.corners.size() << " corners but "
                        << polygon.corner_uvs.size()
                        << " texture coordinates (expected one per corner); " << kReexportHint);
      }
      any_corner_uvs |= !polygon.corner_uvs.empty();
      polygons.push_back(std::move(polygon));
    }
  }
  if (reader.TrailingNonSpaceBytes() > 0) {
    G6D_THROW(where << reader.RemainingBytes() << " bytes follow the last element ("
                    << header.elements.back().name << " " << header.elements.back().count
                    << "); " << kReexportHint);
  }

  // Texture coordinates per face corner: a vertex used with different coordinates becomes
  // one vertex per coordinate (a texture seam), as in OBJ.
  const bool split_corners = any_corner_uvs && !has_uvs;
  std::map<std::tuple<int64_t, float, float>, int> vertex_of_corner;
  std::vector<bool> uv_assigned;
  if (split_corners) {
    mesh.uvs.assign(num_vertices, Eigen::Vector2f::Zero());
    uv_assigned.assign(num_vertices, false);
  }
  std::vector<int> corners;
  for (const Polygon& polygon : polygons) {
    corners.clear();
    for (size_t k = 0; k < polygon.corners.size(); ++k) {
      int index = static_cast<int>(polygon.corners[k]);
      if (split_corners && !polygon.corner_uvs.empty()) {
        const Eigen::Vector2f& uv = polygon.corner_uvs[k];
        const auto key = std::make_tuple(polygon.corners[k], uv.x(), uv.y());
        const auto found = vertex_of_corner.find(key);
        if (found != vertex_of_corner.end()) {
          index = found->second;
        } else {
          if (uv_assigned[index]) {  // a seam: a copy of the vertex with these coordinates
            const size_t original = static_cast<size_t>(index);
            index = static_cast<int>(mesh.positions.size());
            mesh.positions.push_back(mesh.positions[original]);
            if (has_normals) mesh.normals.push_back(mesh.normals[original]);
            if (has_colors) mesh.colors.push_back(mesh.colors[original]);
            mesh.uvs.emplace_back();
            uv_assigned.push_back(true);
          }
          mesh.uvs[static_cast<size_t>(index)] = uv;
          uv_assigned[static_cast<size_t>(index)] = true;
          vertex_of_corner.emplace(key, index);
        }
      }
      corners.push_back(index);
    }
    if (corners.size() < 3) {
      ++mesh.num_points_or_lines;
      continue;
    }
    ++mesh.num_polygons;
    Triangulate(corners, mesh.positions, &mesh.triangles);
  }
  return mesh;
}

}  // namespace g6d
