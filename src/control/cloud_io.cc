// PLY and PCD point cloud files (control/cloud_io.h): the file is read into memory once; binary records are
// decoded with memcpy, ascii numbers with std::from_chars; every read is bounds-checked against the buffer first.
#include "rmpmarl/control/cloud_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string_view>
#include <vector>

#include "rmpmarl/common/error.h"

namespace rmpmarl::control {
namespace {

enum class Scalar { kI8, kU8, kI16, kU16, kI32, kU32, kI64, kU64, kF32, kF64 };

size_t ScalarSize(Scalar s) {
  constexpr std::array<size_t, 10> kSize{1, 1, 2, 2, 4, 4, 8, 8, 4, 8};  // in the order of Scalar
  return kSize[static_cast<size_t>(s)];
}

// one value of type T at p, its bytes reversed when the file's byte order is not the machine's.
template <typename T>
T Load(const char* p, bool swap) {
  std::array<char, sizeof(T)> bytes;
  std::memcpy(bytes.data(), p, sizeof(T));
  if (swap) std::reverse(bytes.begin(), bytes.end());
  T value;
  std::memcpy(&value, bytes.data(), sizeof(T));
  return value;
}

double LoadScalar(const char* p, Scalar s, bool swap) {
  switch (s) {
    case Scalar::kI8: return Load<int8_t>(p, swap);
    case Scalar::kU8: return Load<uint8_t>(p, swap);
    case Scalar::kI16: return Load<int16_t>(p, swap);
    case Scalar::kU16: return Load<uint16_t>(p, swap);
    case Scalar::kI32: return Load<int32_t>(p, swap);
    case Scalar::kU32: return Load<uint32_t>(p, swap);
    case Scalar::kI64: return static_cast<double>(Load<int64_t>(p, swap));
    case Scalar::kU64: return static_cast<double>(Load<uint64_t>(p, swap));
    case Scalar::kF32: return Load<float>(p, swap);
    case Scalar::kF64: return Load<double>(p, swap);
  }
  return 0.0;
}

constexpr bool kLittleEndianHost = std::endian::native == std::endian::little;

[[noreturn]] void Fail(const std::filesystem::path& path, std::string_view message) {
  throw InputError(fmt::format("{}: {}", path.string(), message));
}
[[noreturn]] void FailAt(const std::filesystem::path& path, long line, std::string_view message) {
  throw InputError(fmt::format("{}:{}: {}", path.string(), line, message));
}

// a piece of the file for a message: at most 60 characters, non-printable bytes as '?'.
std::string Shown(std::string_view text) {
  std::string out(text.substr(0, 60));
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e) c = '?';
  }
  if (text.size() > 60) out += "...";
  return out;
}

// lines of a buffer ('\n'-terminated, a trailing '\r' removed), numbered from 1.
class LineReader {
 public:
  explicit LineReader(std::string_view data) : data_(data) {}
  bool Next(std::string_view* line) {
    if (pos_ >= data_.size()) return false;
    const size_t end = data_.find('\n', pos_);
    const size_t stop = end == std::string_view::npos ? data_.size() : end;
    *line = data_.substr(pos_, stop - pos_);
    if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
    pos_ = end == std::string_view::npos ? data_.size() : end + 1;
    ++line_;
    return true;
  }
  // the next line holding a token; false at the end of the data.
  bool NextNonBlank(std::string_view* line) {
    while (Next(line)) {
      if (line->find_first_not_of(" \t\r\v\f") != std::string_view::npos) return true;
    }
    return false;
  }
  size_t pos() const { return pos_; }
  long line() const { return line_; }

 private:
  std::string_view data_;
  size_t pos_ = 0;
  long line_ = 0;
};

void Split(std::string_view line, std::vector<std::string_view>* tokens) {
  tokens->clear();
  size_t i = 0;
  while (true) {
    i = line.find_first_not_of(" \t\r\v\f", i);
    if (i == std::string_view::npos) return;
    const size_t j = std::min(line.find_first_of(" \t\r\v\f", i), line.size());
    tokens->push_back(line.substr(i, j - i));
    i = j;
  }
}

// a whole token as a number of type T (float or double; "nan", "inf" included); a leading '+' is allowed.
template <typename T>
bool ParseNumber(std::string_view token, T* value) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return ec == std::errc() && end == token.data() + token.size();
}

bool ParseCount(std::string_view token, long long* value) {
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return ec == std::errc() && end == token.data() + token.size() && *value >= 0;
}

void CheckPointCount(const std::filesystem::path& path, long long count, const CloudReadOptions& options) {
  if (count > options.max_points) {
    Fail(path, fmt::format("the header declares {} points, more than CloudReadOptions::max_points = {}", count,
                           options.max_points));
  }
}

// a coordinate column: value i at base + i × stride.
struct Column {
  const char* base;
  size_t stride;
  Scalar type;
};

// decodes `count` points from three columns into out (finite points kept, the rest counted).
void DecodeColumns(const std::array<Column, 3>& xyz, long long count, bool swap, PointCloudFile* out) {
  out->points.resize(3, count);
  long kept = 0;
  for (long long i = 0; i < count; ++i) {
    const Eigen::Vector3d p(LoadScalar(xyz[0].base + i * xyz[0].stride, xyz[0].type, swap),
                            LoadScalar(xyz[1].base + i * xyz[1].stride, xyz[1].type, swap),
                            LoadScalar(xyz[2].base + i * xyz[2].stride, xyz[2].type, swap));
    if (p.allFinite()) {
      out->points.col(kept++) = p;
    } else {
      ++out->skipped_nonfinite;
    }
  }
  out->points.conservativeResize(3, kept);
}

// reads `count` ascii points, one per non-blank line of `tokens_per_point` tokens (described by `layout`), x y z
// at token indices xyz; a float32 coordinate is parsed as a float ("0.1" gives 0.1f, as binary data would).
void DecodeAsciiLines(const std::filesystem::path& path, LineReader* reader, std::string_view data, long long count,
                      size_t tokens_per_point, std::string_view layout, const std::array<size_t, 3>& xyz,
                      const std::array<bool, 3>& float32, PointCloudFile* out) {
  // a line of k tokens takes at least 2k − 1 bytes, plus a newline between lines: refuse before allocating
  const size_t remaining = data.size() - reader->pos();
  const long long most = static_cast<long long>((remaining + 1) / (2 * tokens_per_point));
  if (count > most) {
    Fail(path, fmt::format("the header declares {} points of {} values, but the {} bytes of data after the header "
                           "hold at most {} (truncated file?)", count, tokens_per_point, remaining, most));
  }
  out->points.resize(3, count);
  long kept = 0;
  std::vector<std::string_view> tokens;
  std::string_view line;
  for (long long i = 0; i < count; ++i) {
    if (!reader->NextNonBlank(&line)) {
      Fail(path, fmt::format("the header declares {} points, but the data ends after {} (truncated file?)", count, i));
    }
    Split(line, &tokens);
    if (tokens.size() != tokens_per_point) {
      FailAt(path, reader->line(), fmt::format("expected {} values for point {} ({}), found {}", tokens_per_point, i,
                                               layout, tokens.size()));
    }
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k) {
      float f = 0.0f;
      const bool ok = float32[k] ? ParseNumber(tokens[xyz[k]], &f) : ParseNumber(tokens[xyz[k]], &p[k]);
      if (float32[k]) p[k] = f;
      if (!ok) {
        FailAt(path, reader->line(), fmt::format("expected a number for '{}' of point {}, found '{}'", "xyz"[k], i,
                                                 Shown(tokens[xyz[k]])));
      }
    }
    if (p.allFinite()) {
      out->points.col(kept++) = p;
    } else {
      ++out->skipped_nonfinite;
    }
  }
  out->points.conservativeResize(3, kept);
}

// the index of each of x, y, z in names; throws naming what the file has instead.
std::array<size_t, 3> FindXyz(const std::filesystem::path& path, const std::vector<std::string>& names,
                              std::string_view what) {
  std::array<size_t, 3> index{};
  const char* axes[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    const auto it = std::find(names.begin(), names.end(), axes[k]);
    if (it == names.end()) {
      Fail(path, fmt::format("expected {} named x, y and z; '{}' is missing (found: {})", what, axes[k],
                             names.empty() ? "none" : fmt::format("{}", fmt::join(names, " "))));
    }
    index[k] = static_cast<size_t>(it - names.begin());
  }
  return index;
}

// ---- PLY

struct PlyProperty {
  std::string name;
  Scalar type = Scalar::kF32;
  bool is_list = false;
};

struct PlyElement {
  std::string name;
  long long count = 0;
  long line = 0;
  std::vector<PlyProperty> properties;
};

bool PlyScalar(std::string_view name, Scalar* type) {
  static constexpr std::array<std::pair<std::string_view, Scalar>, 16> kTypes{{
      {"char", Scalar::kI8}, {"int8", Scalar::kI8}, {"uchar", Scalar::kU8}, {"uint8", Scalar::kU8},
      {"short", Scalar::kI16}, {"int16", Scalar::kI16}, {"ushort", Scalar::kU16}, {"uint16", Scalar::kU16},
      {"int", Scalar::kI32}, {"int32", Scalar::kI32}, {"uint", Scalar::kU32}, {"uint32", Scalar::kU32},
      {"float", Scalar::kF32}, {"float32", Scalar::kF32}, {"double", Scalar::kF64}, {"float64", Scalar::kF64}}};
  for (const auto& [type_name, value] : kTypes) {
    if (type_name == name) {
      *type = value;
      return true;
    }
  }
  return false;
}

PointCloudFile ReadPly(const std::filesystem::path& path, std::string_view data, const CloudReadOptions& options) {
  LineReader reader(data);
  std::string_view line;
  std::vector<std::string_view> tokens;
  if (!reader.Next(&line) || line != "ply") {
    Fail(path, fmt::format("expected 'ply' on the first line, found '{}'", Shown(line)));
  }
  std::string format;
  std::vector<PlyElement> elements;
  constexpr std::string_view kTypeList =
      "char/int8, uchar/uint8, short/int16, ushort/uint16, int/int32, uint/uint32, float/float32, double/float64";
  while (true) {
    if (!reader.Next(&line)) Fail(path, "the header ends without an 'end_header' line (truncated file?)");
    Split(line, &tokens);
    if (tokens.empty() || tokens[0] == "comment" || tokens[0] == "obj_info") continue;
    const long n = reader.line();
    if (tokens[0] == "end_header") break;
    if (tokens[0] == "format") {
      if (tokens.size() != 3 ||
          (tokens[1] != "ascii" && tokens[1] != "binary_little_endian" && tokens[1] != "binary_big_endian")) {
        FailAt(path, n, fmt::format("expected 'format ascii|binary_little_endian|binary_big_endian 1.0', found '{}'",
                                    Shown(line)));
      }
      format = tokens[1];
    } else if (tokens[0] == "element") {
      long long count = 0;
      if (tokens.size() != 3 || !ParseCount(tokens[2], &count)) {
        FailAt(path, n, fmt::format("expected 'element <name> <count ≥ 0>', found '{}'", Shown(line)));
      }
      elements.push_back({std::string(tokens[1]), count, n, {}});
    } else if (tokens[0] == "property") {
      if (elements.empty()) FailAt(path, n, fmt::format("expected an 'element' line before '{}'", Shown(line)));
      PlyProperty property;
      const bool list = tokens.size() >= 2 && tokens[1] == "list";
      Scalar unused;
      if (list && (tokens.size() != 5 || !PlyScalar(tokens[2], &unused) || !PlyScalar(tokens[3], &unused))) {
        FailAt(path, n, fmt::format("expected 'property list <count type> <item type> <name>' with types among {}, "
                                    "found '{}'", kTypeList, Shown(line)));
      }
      if (!list && (tokens.size() != 3 || !PlyScalar(tokens[1], &property.type))) {
        FailAt(path, n, fmt::format("expected 'property <type> <name>' with a type among {}, found '{}'", kTypeList,
                                    Shown(line)));
      }
      property.is_list = list;
      property.name = tokens.back();
      elements.back().properties.push_back(std::move(property));
    } else {
      FailAt(path, n, fmt::format("expected a PLY header line (format, element, property, comment, obj_info, "
                                  "end_header), found '{}'", Shown(line)));
    }
  }
  if (format.empty()) Fail(path, "expected a 'format' line in the PLY header, found none");
  const auto vertex_it =
      std::find_if(elements.begin(), elements.end(), [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertex_it == elements.end()) Fail(path, "expected an 'element vertex <count>' line in the header, found none");
  const PlyElement& vertex = *vertex_it;
  std::vector<std::string> names;
  for (const PlyProperty& property : vertex.properties) {
    if (property.is_list) {
      Fail(path, fmt::format("expected scalar vertex properties, found list property '{}' on the vertex element "
                             "(line {})", property.name, vertex.line));
    }
    names.push_back(property.name);
  }
  const std::array<size_t, 3> xyz = FindXyz(path, names, "vertex properties");
  CheckPointCount(path, vertex.count, options);

  PointCloudFile out;
  out.format = "ply " + format;
  const auto preceding = std::vector<PlyElement>(elements.begin(), vertex_it);
  if (format == "ascii") {
    for (const PlyElement& element : preceding) {
      for (long long i = 0; i < element.count; ++i) {
        if (!reader.NextNonBlank(&line)) {
          Fail(path, fmt::format("the header declares {} '{}' elements before the vertices, but the data ends after "
                                 "{} (truncated file?)", element.count, element.name, i));
        }
      }
    }
    std::array<bool, 3> float32{};
    for (int k = 0; k < 3; ++k) float32[k] = vertex.properties[xyz[k]].type == Scalar::kF32;
    DecodeAsciiLines(path, &reader, data, vertex.count, names.size(), fmt::format("{}", fmt::join(names, " ")), xyz,
                     float32, &out);
    return out;
  }
  size_t pos = reader.pos();
  for (const PlyElement& element : preceding) {
    size_t size = 0;
    for (const PlyProperty& property : element.properties) {
      if (property.is_list) {
        Fail(path, fmt::format("element '{}' (line {}) has list property '{}' and precedes the vertex element; in a "
                               "binary file its size is unknown: expected every element before 'vertex' to have "
                               "scalar properties only", element.name, element.line, property.name));
      }
      size += ScalarSize(property.type);
    }
    if (size > 0 && static_cast<unsigned long long>(element.count) > (data.size() - pos) / size) {
      Fail(path, fmt::format("the header declares {} '{}' elements of {} bytes before the vertices, but only {} bytes "
                             "follow (truncated file?)", element.count, element.name, size, data.size() - pos));
    }
    pos += element.count * size;
  }
  std::vector<size_t> offsets;
  size_t stride = 0;
  for (const PlyProperty& property : vertex.properties) {
    offsets.push_back(stride);
    stride += ScalarSize(property.type);
  }
  const size_t available = data.size() - pos;
  if (static_cast<unsigned long long>(vertex.count) > available / stride) {
    Fail(path, fmt::format("the header declares {} vertices of {} bytes ({} bytes), but only {} bytes follow "
                           "(truncated file?)", vertex.count, stride, vertex.count * stride, available));
  }
  const bool little = format == "binary_little_endian";
  std::array<Column, 3> columns;
  for (int k = 0; k < 3; ++k) {
    columns[k] = {data.data() + pos + offsets[xyz[k]], stride, vertex.properties[xyz[k]].type};
  }
  DecodeColumns(columns, vertex.count, little != kLittleEndianHost, &out);
  return out;
}

// ---- PCD

struct PcdField {
  std::string name;
  size_t size = 4;
  char type = 'F';
  long long count = 1;
  Scalar scalar = Scalar::kF32;
};

Scalar PcdScalar(char type, size_t size) {
  if (type == 'F') return size == 4 ? Scalar::kF32 : Scalar::kF64;
  const bool u = type == 'U';
  switch (size) {
    case 1: return u ? Scalar::kU8 : Scalar::kI8;
    case 2: return u ? Scalar::kU16 : Scalar::kI16;
    case 4: return u ? Scalar::kU32 : Scalar::kI32;
    default: return u ? Scalar::kU64 : Scalar::kI64;
  }
}

// LZF decompression (liblzf's format, which PCL's binary_compressed uses): a control byte c < 32 starts a literal
// run of c + 1 bytes; any other starts a back-reference of (c >> 5) + 2 bytes (c >> 5 = 7: plus the next byte)
// copied from ((c & 31) << 8) + next byte + 1 bytes back in the output (it may overlap what it writes). Returns an
// empty string, or what is wrong with the input.
std::string LzfDecompress(std::string_view in, std::vector<char>* out) {
  const size_t out_size = out->size();
  size_t ip = 0, op = 0;
  while (ip < in.size()) {
    const unsigned ctrl = static_cast<unsigned char>(in[ip++]);
    if (ctrl < 32) {
      const size_t length = ctrl + 1;
      if (length > in.size() - ip) {
        return fmt::format("a literal run of {} bytes at byte {} runs past the data", length, ip - 1);
      }
      if (length > out_size - op) return fmt::format("the data expands past the declared {} bytes", out_size);
      std::memcpy(out->data() + op, in.data() + ip, length);
      ip += length;
      op += length;
      continue;
    }
    size_t length = ctrl >> 5;
    if (ip >= in.size()) return fmt::format("a back-reference at byte {} is cut off", ip - 1);
    if (length == 7) {
      length += static_cast<unsigned char>(in[ip++]);
      if (ip >= in.size()) return fmt::format("a back-reference at byte {} is cut off", ip - 2);
    }
    length += 2;
    const size_t distance = ((ctrl & 0x1fu) << 8) + static_cast<unsigned char>(in[ip++]) + 1;
    if (distance > op) return fmt::format("a back-reference reaches {} bytes back from output byte {}", distance, op);
    if (length > out_size - op) return fmt::format("the data expands past the declared {} bytes", out_size);
    for (size_t i = 0; i < length; ++i, ++op) (*out)[op] = (*out)[op - distance];
  }
  if (op != out_size) return fmt::format("the data expands to {} bytes, expected {}", op, out_size);
  return {};
}

PointCloudFile ReadPcd(const std::filesystem::path& path, std::string_view data, const CloudReadOptions& options) {
  LineReader reader(data);
  std::string_view line;
  std::vector<std::string_view> tokens;
  std::vector<PcdField> fields;
  bool has_width = false, has_points = false;
  long long width = 0, height = 1, points = 0;
  std::string data_kind;
  while (data_kind.empty()) {
    if (!reader.Next(&line)) Fail(path, "the header ends without a 'DATA' line (truncated file?)");
    Split(line, &tokens);
    if (tokens.empty() || tokens[0][0] == '#' || tokens[0] == "VERSION") continue;
    const std::string_view key = tokens[0];
    const long n = reader.line();
    const size_t values = tokens.size() - 1;
    if (key == "FIELDS" || key == "COLUMNS") {
      if (values == 0) FailAt(path, n, "expected at least one field name after FIELDS, found none");
      fields.clear();
      for (size_t i = 1; i < tokens.size(); ++i) fields.push_back({std::string(tokens[i])});
    } else if (key == "SIZE" || key == "TYPE" || key == "COUNT") {
      if (fields.empty() || values != fields.size()) {
        FailAt(path, n, fmt::format("expected {} after FIELDS, one per field ({}), found {} values", key,
                                    fields.size(), values));
      }
      for (size_t i = 0; i < values; ++i) {
        const std::string_view t = tokens[i + 1];
        long long v = 0;
        const bool ok = key == "TYPE" ? (t == "F" || t == "I" || t == "U")
                                      : ParseCount(t, &v) && v >= 1 && v <= (key == "SIZE" ? 8 : 1 << 24);
        if (!ok) {
          FailAt(path, n, fmt::format("expected {} of field '{}' to be {}, found '{}'", key, fields[i].name,
                                      key == "TYPE" ? "F, I or U" : key == "SIZE" ? "1, 2, 4 or 8" : "in [1, 2^24]",
                                      Shown(t)));
        }
        if (key == "TYPE") fields[i].type = t[0];
        if (key == "SIZE") fields[i].size = static_cast<size_t>(v);
        if (key == "COUNT") fields[i].count = v;
      }
    } else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
      long long v = 0;
      if (values != 1 || !ParseCount(tokens[1], &v)) {
        FailAt(path, n, fmt::format("expected '{} <count ≥ 0>', found '{}'", key, Shown(line)));
      }
      (key == "WIDTH" ? width : key == "HEIGHT" ? height : points) = v;
      has_width = has_width || key == "WIDTH";
      has_points = has_points || key == "POINTS";
    } else if (key == "VIEWPOINT") {
      double v = 0.0;
      bool ok = values == 7;
      for (size_t i = 1; ok && i < tokens.size(); ++i) ok = ParseNumber(tokens[i], &v);
      if (!ok) FailAt(path, n, fmt::format("expected 'VIEWPOINT tx ty tz qw qx qy qz', found '{}'", Shown(line)));
    } else if (key == "DATA") {
      if (values != 1 || (tokens[1] != "ascii" && tokens[1] != "binary" && tokens[1] != "binary_compressed")) {
        FailAt(path, n, fmt::format("expected 'DATA ascii|binary|binary_compressed', found '{}'", Shown(line)));
      }
      data_kind = tokens[1];
    } else {
      FailAt(path, n, fmt::format("expected a PCD header line (VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, "
                                  "VIEWPOINT, POINTS, DATA), found '{}'", Shown(line)));
    }
  }
  if (fields.empty()) Fail(path, "expected a FIELDS line in the PCD header, found none");
  std::vector<std::string> names;  // of the fields
  std::string layout;              // of an ascii line: the fields, with their COUNT when not 1
  size_t tokens_per_point = 0;
  for (PcdField& field : fields) {
    const size_t s = field.size;
    const bool ok = field.type == 'F' ? (s == 4 || s == 8) : (s == 1 || s == 2 || s == 4 || s == 8);
    if (!ok) {
      Fail(path, fmt::format("field '{}': expected SIZE {} for TYPE {}, found {}", field.name,
                             field.type == 'F' ? "4 or 8" : "1, 2, 4 or 8", field.type, s));
    }
    if ((field.name == "x" || field.name == "y" || field.name == "z") && field.count != 1) {
      Fail(path, fmt::format("expected COUNT 1 for field '{}', found {}", field.name, field.count));
    }
    field.scalar = PcdScalar(field.type, s);
    names.push_back(field.name);
    layout += (layout.empty() ? "" : " ") + field.name + (field.count == 1 ? "" : fmt::format("[{}]", field.count));
    tokens_per_point += field.count;
  }
  const std::array<size_t, 3> field_of = FindXyz(path, names, "fields");
  if (has_width) {
    if (height != 0 && width > std::numeric_limits<long long>::max() / height) {
      Fail(path, fmt::format("WIDTH × HEIGHT = {} × {} overflows", width, height));
    }
    if (has_points && width * height != points) {
      Fail(path, fmt::format("expected POINTS = WIDTH × HEIGHT = {} × {}, found POINTS {}", width, height, points));
    }
    points = width * height;
  } else if (!has_points) {
    Fail(path, "expected a POINTS or WIDTH line in the PCD header, found neither");
  }
  CheckPointCount(path, points, options);

  PointCloudFile out;
  out.format = "pcd " + data_kind;
  if (data_kind == "ascii") {
    std::array<size_t, 3> token{};  // of each coordinate: the COUNTs of the fields before it
    std::array<bool, 3> float32{};
    for (int k = 0; k < 3; ++k) {
      for (size_t f = 0; f < field_of[k]; ++f) token[k] += fields[f].count;
      float32[k] = fields[field_of[k]].scalar == Scalar::kF32;
    }
    DecodeAsciiLines(path, &reader, data, points, tokens_per_point, layout, token, float32, &out);
    return out;
  }
  const size_t pos = reader.pos();
  const size_t available = data.size() - pos;
  std::array<Column, 3> columns;
  if (data_kind == "binary") {
    size_t stride = 0;
    std::vector<size_t> offsets;
    for (const PcdField& field : fields) {
      offsets.push_back(stride);
      stride += field.size * field.count;
    }
    if (static_cast<unsigned long long>(points) > available / stride) {
      Fail(path, fmt::format("the header declares {} points of {} bytes ({} bytes), but only {} bytes follow "
                             "(truncated file?)", points, stride, points * stride, available));
    }
    for (int k = 0; k < 3; ++k) {
      columns[k] = {data.data() + pos + offsets[field_of[k]], stride, fields[field_of[k]].scalar};
    }
    DecodeColumns(columns, points, !kLittleEndianHost, &out);
    return out;
  }
  if (points == 0) return out;
  if (available < 8) {
    Fail(path, fmt::format("expected 8 bytes of compressed and uncompressed size after 'DATA binary_compressed', "
                           "found {} (truncated file?)", available));
  }
  const uint32_t compressed = Load<uint32_t>(data.data() + pos, !kLittleEndianHost);
  const uint32_t uncompressed = Load<uint32_t>(data.data() + pos + 4, !kLittleEndianHost);
  if (compressed > available - 8) {
    Fail(path, fmt::format("the compressed data is declared {} bytes, but only {} bytes follow (truncated file?)",
                           compressed, available - 8));
  }
  size_t point_size = 0;  // without the padding fields "_", which binary_compressed leaves out
  for (const PcdField& field : fields) point_size += field.name == "_" ? 0 : field.size * field.count;
  if (uncompressed % point_size != 0 || uncompressed / point_size != static_cast<unsigned long long>(points)) {
    Fail(path, fmt::format("expected an uncompressed size of {} points × {} bytes = {} bytes, found {}", points,
                           point_size, points * point_size, uncompressed));
  }
  std::vector<char> planes(uncompressed);
  const std::string problem = LzfDecompress(data.substr(pos + 8, compressed), &planes);
  if (!problem.empty()) Fail(path, fmt::format("corrupt LZF data in binary_compressed: {}", problem));
  size_t plane = 0;
  for (size_t f = 0; f < fields.size(); ++f) {
    if (fields[f].name == "_") continue;
    const size_t size = fields[f].size * fields[f].count;
    for (int k = 0; k < 3; ++k) {
      if (field_of[k] == f) columns[k] = {planes.data() + plane, size, fields[f].scalar};
    }
    plane += size * points;
  }
  DecodeColumns(columns, points, !kLittleEndianHost, &out);
  return out;
}

// ---- files

std::string ReadWholeFile(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) Fail(path, "expected a point cloud file, found a directory");
  std::ifstream file(path, std::ios::binary);
  if (!file) Fail(path, "cannot open point cloud file (missing or unreadable)");
  file.seekg(0, std::ios::end);
  const std::streamoff size = file.tellg();
  file.seekg(0, std::ios::beg);
  if (size < 0) Fail(path, "cannot determine the file's size");
  std::string bytes(static_cast<size_t>(size), '\0');
  if (!file.read(bytes.data(), size)) Fail(path, "read error");
  return bytes;
}

void WriteWholeFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) Fail(path, "cannot open for writing");
  file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  file.close();
  if (!file) Fail(path, "write failed (disk full?)");
}

// the points as float32 little-endian x y z records, or as ascii lines "x y z".
void AppendPoints(const Eigen::Matrix3Xd& points, bool binary, std::string* out) {
  if (binary) {
    const size_t start = out->size();
    out->resize(start + 12 * static_cast<size_t>(points.cols()));
    char* p = out->data() + start;
    for (Eigen::Index i = 0; i < points.cols(); ++i) {
      for (int k = 0; k < 3; ++k, p += 4) {
        std::array<char, 4> bytes = std::bit_cast<std::array<char, 4>>(static_cast<float>(points(k, i)));
        if (!kLittleEndianHost) std::reverse(bytes.begin(), bytes.end());
        std::memcpy(p, bytes.data(), 4);
      }
    }
    return;
  }
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    fmt::format_to(std::back_inserter(*out), "{} {} {}\n", static_cast<float>(points(0, i)),
                   static_cast<float>(points(1, i)), static_cast<float>(points(2, i)));
  }
}

std::string LowerExtension(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

}  // namespace

PointCloudFile ReadPointCloud(const std::filesystem::path& path, const CloudReadOptions& options) {
  if (options.max_points < 0) {
    throw InputError(fmt::format("CloudReadOptions.max_points: expected ≥ 0, got {}", options.max_points));
  }
  const std::string extension = LowerExtension(path);
  if (extension != ".ply" && extension != ".pcd") {
    Fail(path, fmt::format("unsupported point cloud extension '{}': expected .ply or .pcd", extension));
  }
  const std::string bytes = ReadWholeFile(path);
  return extension == ".ply" ? ReadPly(path, bytes, options) : ReadPcd(path, bytes, options);
}

void WritePly(const std::filesystem::path& path, const Eigen::Matrix3Xd& points, bool binary) {
  std::string out = fmt::format(
      "ply\nformat {} 1.0\ncomment written by rmpmarl\nelement vertex {}\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n", binary ? "binary_little_endian" : "ascii", points.cols());
  AppendPoints(points, binary, &out);
  WriteWholeFile(path, out);
}

void WritePcd(const std::filesystem::path& path, const Eigen::Matrix3Xd& points, bool binary) {
  std::string out = fmt::format(
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
      "COUNT 1 1 1\nWIDTH {}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {}\n", points.cols(), points.cols(),
      binary ? "binary" : "ascii");
  AppendPoints(points, binary, &out);
  WriteWholeFile(path, out);
}

}  // namespace rmpmarl::control
