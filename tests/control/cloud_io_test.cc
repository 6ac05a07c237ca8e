// Point cloud files (control/cloud_io.h): Write→Read round trips of both formats and encodings (exact for float32
// values), hand-written PLY and PCD files (extra properties and fields, elements around the vertices, big-endian
// bytes, padding, organised clouds with NaN, LZF data with back-references), every malformed case with the path and
// the problem in the message, truncated and corrupted files (an InputError, never a crash), and the time to read a
// million points (printed).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/cloud_io.h"

namespace rmpmarl::control {
namespace {

using Eigen::Matrix3Xd;

// float32-representable points (so a float32 file holds them exactly), including extreme magnitudes.
Matrix3Xd RandomFloatPoints(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  Matrix3Xd points(3, n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) points(k, i) = u(rng);
  }
  if (n >= 2) {
    points.col(0) << 3.4e38f, -1.17549435e-38f, 1e-40f;  // largest, smallest normal, subnormal
    points.col(1) << 0.1f, -0.0f, 123456.789f;
  }
  return points;
}

template <typename T>
void Append(std::string* out, T value, bool big_endian = false) {
  std::array<char, sizeof(T)> bytes = std::bit_cast<std::array<char, sizeof(T)>>(value);
  if (big_endian == (std::endian::native == std::endian::little)) std::reverse(bytes.begin(), bytes.end());
  out->append(bytes.data(), bytes.size());
}

// LZF with literal runs only (control byte = run length − 1, at most 32 bytes per run): valid, uncompressed.
std::string LzfLiteral(const std::string& data) {
  std::string out;
  for (size_t i = 0; i < data.size(); i += 32) {
    const size_t n = std::min<size_t>(32, data.size() - i);
    out.push_back(static_cast<char>(n - 1));
    out.append(data, i, n);
  }
  return out;
}

// an LZF back-reference: copy `length` (3..264) bytes from `distance` (1..8192) bytes back in the output.
void LzfBackReference(std::string* out, size_t length, size_t distance) {
  const size_t l = length - 2, d = distance - 1;
  if (l < 7) {
    out->push_back(static_cast<char>((l << 5) | (d >> 8)));
  } else {
    out->push_back(static_cast<char>((7 << 5) | (d >> 8)));
    out->push_back(static_cast<char>(l - 7));
  }
  out->push_back(static_cast<char>(d & 0xff));
}

// a binary_compressed PCD: header fields, then the two sizes and the LZF data.
std::string CompressedPcd(const std::string& fields, long points, const std::string& lzf, uint32_t uncompressed) {
  std::string out = fmt::format("VERSION 0.7\n{}WIDTH {}\nHEIGHT 1\nPOINTS {}\nDATA binary_compressed\n", fields,
                                points, points);
  Append<uint32_t>(&out, static_cast<uint32_t>(lzf.size()));
  Append<uint32_t>(&out, uncompressed);
  return out + lzf;
}

class CloudIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           fmt::format("rmpmarl-cloud-io-{}-{}", ::getpid(),
                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::filesystem::path Write(const std::string& name, const std::string& bytes) {
    const auto path = dir_ / name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  // reading `path` throws an InputError naming the path and containing every one of `parts`.
  static void ExpectReadError(const std::filesystem::path& path, const std::vector<std::string>& parts,
                              const CloudReadOptions& options = {}) {
    try {
      ReadPointCloud(path, options);
      ADD_FAILURE() << path << ": read without an error";
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(path.string()), std::string::npos) << message;
      for (const std::string& part : parts) EXPECT_NE(message.find(part), std::string::npos) << message;
    }
  }
  std::filesystem::path dir_;
};

TEST_F(CloudIoTest, WriteThenReadIsExactForBothFormatsAndEncodings) {
  const Matrix3Xd points = RandomFloatPoints(500, 1);
  for (const bool binary : {true, false}) {
    for (const std::string extension : {"ply", "pcd"}) {
      const auto path = dir_ / ("cloud." + extension);
      (extension == "ply" ? WritePly : WritePcd)(path, points, binary);
      const PointCloudFile read = ReadPointCloud(path);
      EXPECT_EQ(read.format, extension + (binary ? (extension == "ply" ? " binary_little_endian" : " binary")
                                                 : " ascii"));
      ASSERT_EQ(read.points.cols(), points.cols()) << read.format;
      EXPECT_EQ((read.points - points).cwiseAbs().maxCoeff(), 0.0) << read.format;
      EXPECT_EQ(read.skipped_nonfinite, 0);
    }
  }
}

TEST_F(CloudIoTest, NonFinitePointsAreDroppedAndCounted) {
  Matrix3Xd points = RandomFloatPoints(6, 2);
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  points(1, 1) = nan;
  points(2, 4) = -inf;
  for (const bool binary : {true, false}) {
    for (const auto& write : {WritePly, WritePcd}) {
      const auto path = dir_ / (write == WritePly ? "c.ply" : "c.pcd");
      write(path, points, binary);
      const PointCloudFile read = ReadPointCloud(path);
      EXPECT_EQ(read.skipped_nonfinite, 2) << read.format;
      ASSERT_EQ(read.points.cols(), 4) << read.format;
      EXPECT_EQ(read.points.col(1), points.col(2));
      EXPECT_EQ(read.points.col(3), points.col(5));
    }
  }
}

TEST_F(CloudIoTest, PlyAsciiWithExtraPropertiesCommentsAndFacesAfterTheVertices) {
  const auto path = Write("mesh.PLY",  // the extension in any case
                          "ply\nformat ascii 1.0\ncomment made by hand\nobj_info scanner 3\nelement vertex 3\n"
                          "property float nx\nproperty float32 y\nproperty uchar red\nproperty double x\n"
                          "property float ny\nproperty int z\n"
                          "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                          "0 1.5 255 -2.25 0 7\n"
                          "  0.5\t+2 0 1e-3 1 -8  \r\n"
                          "\n"
                          "1 -0 17 3 0 0\n"
                          "3 0 1 2\n");
  const PointCloudFile read = ReadPointCloud(path);
  EXPECT_EQ(read.format, "ply ascii");
  ASSERT_EQ(read.points.cols(), 3);
  EXPECT_EQ(read.points.col(0), Eigen::Vector3d(-2.25, 1.5, 7));
  EXPECT_EQ(read.points.col(1), Eigen::Vector3d(1e-3, 2, -8));
  EXPECT_EQ(read.points.col(2), Eigen::Vector3d(3, 0, 0));
}

TEST_F(CloudIoTest, PlyAsciiSkipsElementsBeforeTheVertices) {
  const auto path = Write("pre.ply",
                          "ply\nformat ascii 1.0\nelement camera 1\nproperty float fx\nproperty float fy\n"
                          "element edge 2\nproperty list uchar int ends\nelement vertex 2\nproperty float x\n"
                          "property float y\nproperty float z\nend_header\n"
                          "500 500\n2 0 1\n3 0 1 1\n"
                          "1 2 3\n4 5 6\n");
  const PointCloudFile read = ReadPointCloud(path);
  ASSERT_EQ(read.points.cols(), 2);
  EXPECT_EQ(read.points.col(1), Eigen::Vector3d(4, 5, 6));
}

// big-endian binary written byte by byte: an element before the vertices, mixed types, a face list after them.
TEST_F(CloudIoTest, PlyBinaryBigEndianByHand) {
  std::string bytes =
      "ply\r\nformat binary_big_endian 1.0\r\nelement camera 2\r\nproperty float a\r\nproperty uchar b\r\n"
      "element vertex 3\r\nproperty uchar red\r\nproperty double x\r\nproperty float32 y\r\nproperty int16 z\r\n"
      "property uint8 alpha\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n";
  for (int i = 0; i < 2; ++i) {
    Append<float>(&bytes, 1.0f + i, true);
    Append<uint8_t>(&bytes, 9, true);
  }
  const double x[3] = {0.125, -1e10, 3.0};
  const float y[3] = {-2.5f, 0.75f, 1e-3f};
  const int16_t z[3] = {-300, 0, 32767};
  for (int i = 0; i < 3; ++i) {
    Append<uint8_t>(&bytes, 200, true);
    Append<double>(&bytes, x[i], true);
    Append<float>(&bytes, y[i], true);
    Append<int16_t>(&bytes, z[i], true);
    Append<uint8_t>(&bytes, 255, true);
  }
  bytes.push_back(3);
  for (int i = 0; i < 3; ++i) Append<int32_t>(&bytes, i, true);
  const PointCloudFile read = ReadPointCloud(Write("be.ply", bytes));
  EXPECT_EQ(read.format, "ply binary_big_endian");
  ASSERT_EQ(read.points.cols(), 3);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(read.points.col(i), Eigen::Vector3d(x[i], y[i], z[i])) << i;
}

TEST_F(CloudIoTest, PlyBinaryLittleEndianIntegerTypes) {
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty int32 x\nproperty ushort y\n"
      "property char z\nproperty float64 intensity\nproperty uint w\nend_header\n";
  for (int i = 0; i < 2; ++i) {
    Append<int32_t>(&bytes, -100000 * (i + 1));
    Append<uint16_t>(&bytes, 65535);
    Append<int8_t>(&bytes, static_cast<int8_t>(-128 + i));
    Append<double>(&bytes, 0.5);
    Append<uint32_t>(&bytes, 7);
  }
  const PointCloudFile read = ReadPointCloud(Write("le.ply", bytes));
  ASSERT_EQ(read.points.cols(), 2);
  EXPECT_EQ(read.points.col(1), Eigen::Vector3d(-200000, 65535, -127));
}

TEST_F(CloudIoTest, PcdWithRgbNormalsAndPaddingFields) {
  const std::string header =
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z _ rgb normal_x intensity _\nSIZE 4 4 4 1 4 8 2 1\n"
      "TYPE F F F U F F U I\nCOUNT 1 1 1 4 1 1 1 6\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 1 2 3 0 1 0 0\nPOINTS 2\n";
  const Matrix3Xd expected = (Matrix3Xd(3, 2) << 0.5, -1.0, 1.25, 2.0, -3.5, 4.0).finished();
  std::string binary = header + "DATA binary\n";
  for (int i = 0; i < 2; ++i) {
    for (int k = 0; k < 3; ++k) Append<float>(&binary, static_cast<float>(expected(k, i)));
    binary.append(4, '\x7f');                       // padding
    Append<float>(&binary, std::bit_cast<float>(0x00ff8040u));  // packed rgb
    Append<double>(&binary, 0.25);
    Append<uint16_t>(&binary, 1000);
    binary.append(6, '\xff');
  }
  // the VIEWPOINT (a sensor pose) is not applied: the points stay as stored
  const std::string ascii = header + "DATA ascii\n0.5 1.25 -3.5 0 0 0 0 4.2108e-39 0.25 1000 1 2 3 4 5 6\n"
                                     "-1 2 4 0 0 0 0 0 0 0 0 0 0 0 0 0\n";
  for (const auto& [name, bytes] : std::vector<std::pair<std::string, std::string>>{{"rgb.pcd", binary},
                                                                                    {"rgb_ascii.pcd", ascii}}) {
    const PointCloudFile read = ReadPointCloud(Write(name, bytes));
    ASSERT_EQ(read.points.cols(), 2) << name;
    EXPECT_EQ(read.points, expected) << name;
  }
}

TEST_F(CloudIoTest, OrganisedPcdWithNanPoints) {
  const std::string header = "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 2\n"
                             "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\n";
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float values[6][3] = {{1, 2, 3}, {nan, nan, nan}, {4, 5, 6}, {7, nan, 9}, {10, 11, 12}, {nan, 0, 0}};
  std::string binary = header + "DATA binary\n", ascii = header + "DATA ascii\n";
  for (const auto& p : values) {
    for (float v : p) Append<float>(&binary, v);
    ascii += fmt::format("{} {} {}\n", p[0], p[1], p[2]);
  }
  for (const auto& bytes : {binary, ascii}) {
    const PointCloudFile read = ReadPointCloud(Write("organised.pcd", bytes));
    EXPECT_EQ(read.skipped_nonfinite, 3) << read.format;
    ASSERT_EQ(read.points.cols(), 3) << read.format;
    EXPECT_EQ(read.points.col(2), Eigen::Vector3d(10, 11, 12));
  }
}

TEST_F(CloudIoTest, PcdOlderHeadersAsPclReadsThem) {
  // no VERSION, COUNT, WIDTH or HEIGHT; then COLUMNS without SIZE or TYPE (float32 by default) and no POINTS
  const PointCloudFile a = ReadPointCloud(Write("a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 2\n"
                                                         "DATA ascii\n1 2 3\n4 5 6\n"));
  EXPECT_EQ(a.points.cols(), 2);
  std::string bytes = "COLUMNS intensity x y z\nWIDTH 1\nDATA binary\n";
  for (float v : {9.0f, 1.0f, 2.0f, 3.0f}) Append<float>(&bytes, v);
  const PointCloudFile b = ReadPointCloud(Write("b.pcd", bytes));
  ASSERT_EQ(b.points.cols(), 1);
  EXPECT_EQ(b.points.col(0), Eigen::Vector3d(1, 2, 3));
}

// binary_compressed through a literal-only LZF encoder: planes per field, the padding field left out.
TEST_F(CloudIoTest, PcdBinaryCompressedLiteralRuns) {
  const Matrix3Xd points = RandomFloatPoints(50, 3);
  std::string planes;
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < 50; ++i) Append<float>(&planes, static_cast<float>(points(k, i)));
  }
  for (int i = 0; i < 50; ++i) Append<uint8_t>(&planes, static_cast<uint8_t>(i));
  const std::string fields = "FIELDS x y z _ intensity\nSIZE 4 4 4 1 1\nTYPE F F F U U\nCOUNT 1 1 1 3 1\n";
  const PointCloudFile read = ReadPointCloud(
      Write("c.pcd", CompressedPcd(fields, 50, LzfLiteral(planes), static_cast<uint32_t>(planes.size()))));
  EXPECT_EQ(read.format, "pcd binary_compressed");
  ASSERT_EQ(read.points.cols(), 50);
  EXPECT_EQ(read.points, points);
}

// back-references by hand: long lengths, distances above 255 (the control byte's offset bits), overlapping copies
// and a copy across planes (z copies x).
TEST_F(CloudIoTest, PcdBinaryCompressedBackReferences) {
  std::string lzf;
  for (const float value : {1.0f, 2.0f}) {  // x, then y: the value once, then copies of the bytes before
    std::string literal;
    Append<float>(&literal, value);
    lzf += LzfLiteral(literal);
    LzfBackReference(&lzf, 264, 4);  // overlapping: repeats the 4 bytes
    LzfBackReference(&lzf, 132, 4);
  }
  LzfBackReference(&lzf, 264, 800);  // z = x: 800 bytes back
  LzfBackReference(&lzf, 136, 800);
  const unsigned char by_hand[] = {0x03, 0x00, 0x00, 0x80, 0x3f, 0xe0, 0x03, 0x03, 0xc0, 0x03};  // 1.0f × 6
  const std::string fields = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  const PointCloudFile read = ReadPointCloud(Write("c.pcd", CompressedPcd(fields, 100, lzf, 1200)));
  ASSERT_EQ(read.points.cols(), 100);
  EXPECT_TRUE((read.points.row(0).array() == 1.0).all());
  EXPECT_TRUE((read.points.row(1).array() == 2.0).all());
  EXPECT_TRUE((read.points.row(2).array() == 1.0).all());
  const std::string two_points(reinterpret_cast<const char*>(by_hand), sizeof(by_hand));
  const PointCloudFile small = ReadPointCloud(Write("d.pcd", CompressedPcd(fields, 2, two_points, 24)));
  EXPECT_EQ(small.points, Matrix3Xd::Ones(3, 2));
}

TEST_F(CloudIoTest, ZeroPointsIsAnEmptyCloud) {
  for (const bool binary : {true, false}) {
    for (const auto& write : {WritePly, WritePcd}) {
      const auto path = dir_ / (write == WritePly ? "e.ply" : "e.pcd");
      write(path, Matrix3Xd(3, 0), binary);
      EXPECT_EQ(ReadPointCloud(path).points.cols(), 0);
    }
  }
  const std::string fields = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  EXPECT_EQ(ReadPointCloud(Write("c.pcd", CompressedPcd(fields, 0, "", 0))).points.cols(), 0);
}

TEST_F(CloudIoTest, MaxPointsGuard) {
  for (const auto& write : {WritePly, WritePcd}) {
    const auto path = dir_ / (write == WritePly ? "m.ply" : "m.pcd");
    write(path, RandomFloatPoints(10, 4), true);
    EXPECT_EQ(ReadPointCloud(path, {.max_points = 10}).points.cols(), 10);
    ExpectReadError(path, {"10 points", "max_points = 9"}, {.max_points = 9});
  }
  EXPECT_THROW(ReadPointCloud(dir_ / "m.ply", {.max_points = -1}), InputError);
}

TEST_F(CloudIoTest, UnsupportedExtensionMissingFileAndDirectory) {
  ExpectReadError(Write("cloud.xyz", "1 2 3\n"), {"'.xyz'", ".ply or .pcd"});
  ExpectReadError(dir_ / "absent.ply", {"cannot open"});
  std::filesystem::create_directories(dir_ / "folder.pcd");
  ExpectReadError(dir_ / "folder.pcd", {"directory"});
}

TEST_F(CloudIoTest, MalformedPlyFilesNameThePathAndTheProblem) {
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  const std::string ascii = "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz + "end_header\n";
  const std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 10\n" + xyz + "end_header\n";
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"PLY\nformat ascii 1.0\n", {"expected 'ply' on the first line, found 'PLY'"}},
      {"ply\nformat ascii 1.0\nelement vertex 3\n" + xyz, {"without an 'end_header'", "truncated"}},
      {"ply\nformat utf8 1.0\nend_header\n", {":2:", "found 'format utf8 1.0'"}},
      {"ply\nelement vertex 1\n" + xyz + "end_header\n1 2 3\n", {"expected a 'format' line"}},
      {"ply\nformat ascii 1.0\nelement vertex -3\n", {":3:", "count ≥ 0", "'element vertex -3'"}},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\n", {":4:", "float/float32", "float128"}},
      {"ply\nformat ascii 1.0\nproperty float x\n", {"expected an 'element' line before"}},
      {"ply\nformat ascii 1.0\nelement vertex 1\nbogus\n", {":4:", "found 'bogus'"}},
      {"ply\nformat ascii 1.0\nelement face 0\nend_header\n", {"'element vertex <count>'"}},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
       {"'z' is missing", "found: x y"}},
      {"ply\nformat ascii 1.0\nelement vertex 1\n" + xyz + "property list uchar int n\nend_header\n",
       {"list property 'n' on the vertex element"}},
      {ascii + "1 2 3\n4 5 6.0000\n", {"declares 3 points", "ends after 2", "truncated"}},
      {ascii + "1 2 3\n4 abc 6\n7 8 9\n", {":9:", "a number for 'y' of point 1", "found 'abc'"}},
      {ascii + "1 2 3\n4 5.5.5 6\n7 8 9\n", {":9:", "found '5.5.5'"}},
      {ascii + "1 2 3\n4 5\n7 8 9.000\n", {":9:", "expected 3 values for point 1 (x y z), found 2"}},
      {ascii + "1 2 3 4\n4 5 6\n7 8 9\n", {":8:", "expected 3 values for point 0", "found 4"}},
      {"ply\nformat ascii 1.0\nelement vertex 1000\n" + xyz + "end_header\n1 2 3\n",
       {"declares 1000 points", "hold at most"}},
      {binary + std::string(12 * 9 + 5, '\0'), {"declares 10 vertices of 12 bytes (120 bytes)", "only 113 bytes"}},
      {"ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
       "element vertex 1\n" + xyz + "end_header\n",
       {"element 'face' (line 3) has list property 'vertex_indices' and precedes the vertex element"}},
      {"ply\nformat binary_big_endian 1.0\nelement camera 3\nproperty double f\nelement vertex 0\n" + xyz +
           "end_header\n" + std::string(20, '\0'),
       {"declares 3 'camera' elements of 8 bytes", "only 20 bytes"}},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE(cases[i].first);
    ExpectReadError(Write(fmt::format("bad{}.ply", i), cases[i].first), cases[i].second);
  }
}

TEST_F(CloudIoTest, MalformedPcdFilesNameThePathAndTheProblem) {
  const std::string fields = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  std::string valid_lzf = LzfLiteral(std::string(24, '\0'));
  std::string cut_short = CompressedPcd(fields, 2, valid_lzf, 24);
  cut_short.pop_back();
  std::string bad_reference = LzfLiteral(std::string(4, '\0'));
  LzfBackReference(&bad_reference, 20, 5);  // 5 bytes back from output byte 4
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {fields + "WIDTH 2\nPOINTS 2\n", {"without a 'DATA' line", "truncated"}},
      {"SIZE 4 4 4\n", {":1:", "expected SIZE after FIELDS, one per field (0)"}},
      {fields + "TYPE F F\n", {":5:", "one per field (3), found 2 values"}},
      {"FIELDS x y z\nTYPE F F X\n", {"TYPE of field 'z' to be F, I or U, found 'X'"}},
      {"FIELDS x y z\nSIZE 4 4 16\n", {"SIZE of field 'z' to be 1, 2, 4 or 8, found '16'"}},
      {"FIELDS x y z\nSIZE 4 4 2\nPOINTS 0\nDATA ascii\n", {"field 'z': expected SIZE 4 or 8 for TYPE F, found 2"}},
      {"FIELDS x y z\nWIDTH abc\n", {":2:", "'WIDTH <count ≥ 0>'", "found 'WIDTH abc'"}},
      {"FIELDS x y z\nVIEWPOINT 0 0 0 1 0 0\n", {"'VIEWPOINT tx ty tz qw qx qy qz'"}},
      {"FIELDS x y z\nDATA binary_lz4\n", {"'DATA ascii|binary|binary_compressed', found 'DATA binary_lz4'"}},
      {"FIELDS x y z\nRANGE 5\n", {":2:", "found 'RANGE 5'"}},
      {"WIDTH 1\nDATA ascii\n1 2 3\n", {"expected a FIELDS line"}},
      {"FIELDS x y\nWIDTH 1\nDATA ascii\n1 2\n", {"'z' is missing", "found: x y"}},
      {"FIELDS x y z\nCOUNT 2 1 1\nWIDTH 1\nDATA ascii\n1 2 3 4\n", {"COUNT 1 for field 'x', found 2"}},
      {"FIELDS x y z\nDATA ascii\n", {"expected a POINTS or WIDTH line"}},
      {fields + "WIDTH 3\nHEIGHT 2\nPOINTS 5\nDATA ascii\n", {"POINTS = WIDTH × HEIGHT = 3 × 2, found POINTS 5"}},
      {fields + "WIDTH 3\nDATA ascii\n1 2 3\n4 5 6.0000\n", {"declares 3 points", "ends after 2"}},
      {fields + "WIDTH 2\nDATA ascii\n1 2 3\n4 5 nan6\n", {":8:", "a number for 'z' of point 1, found 'nan6'"}},
      {fields + "WIDTH 2\nDATA binary\n" + std::string(23, '\0'),
       {"declares 2 points of 12 bytes (24 bytes), but only 23 bytes"}},
      {fields + "WIDTH 2\nDATA binary_compressed\n\x05", {"expected 8 bytes of compressed and uncompressed size"}},
      {cut_short, {"declared 25 bytes, but only 24 bytes follow", "truncated"}},
      {CompressedPcd(fields, 2, valid_lzf, 32), {"uncompressed size of 2 points × 12 bytes = 24 bytes, found 32"}},
      {CompressedPcd(fields, 2, bad_reference, 24), {"corrupt LZF", "reaches 5 bytes back from output byte 4"}},
      {CompressedPcd(fields, 2, LzfLiteral(std::string(20, '\0')), 24), {"expands to 20 bytes, expected 24"}},
      {CompressedPcd(fields, 1, LzfLiteral(std::string(24, '\0')), 12), {"expands past the declared 12 bytes"}},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    SCOPED_TRACE(cases[i].first);
    ExpectReadError(Write(fmt::format("bad{}.pcd", i), cases[i].first), cases[i].second);
  }
}

// every prefix of a valid file, and the file with each byte replaced (by 0, 255 or '9'), reads or throws InputError (under ASan: no
// read past a buffer).
TEST_F(CloudIoTest, TruncatedAndCorruptedFilesThrowInputErrorOnly) {
  const Matrix3Xd points = RandomFloatPoints(4, 5);
  std::vector<std::pair<std::string, std::string>> files;
  for (const bool binary : {true, false}) {
    for (const auto& write : {WritePly, WritePcd}) {
      const auto path = dir_ / (write == WritePly ? "v.ply" : "v.pcd");
      write(path, points, binary);
      std::ifstream in(path, std::ios::binary);
      files.emplace_back(path.extension().string(), std::string(std::istreambuf_iterator<char>(in), {}));
    }
  }
  std::string lzf;
  Append<float>(&lzf, 1.0f);
  lzf = LzfLiteral(lzf);
  LzfBackReference(&lzf, 44, 4);
  files.emplace_back(".pcd", CompressedPcd("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n", 4, lzf, 48));
  int errors = 0, reads = 0;
  for (const auto& [extension, bytes] : files) {
    std::vector<std::string> variants;
    for (size_t n = 0; n < bytes.size(); ++n) variants.push_back(bytes.substr(0, n));
    for (size_t i = 0; i < bytes.size(); ++i) {
      variants.push_back(bytes.substr(0, i) + std::array<char, 3>{'\0', '\xff', '9'}[i % 3] + bytes.substr(i + 1));
    }
    for (const std::string& variant : variants) {
      try {
        ReadPointCloud(Write("t" + extension, variant));
        ++reads;
      } catch (const InputError&) {
        ++errors;
      }
    }
  }
  std::printf("truncated/corrupted variants: %d read, %d refused\n", reads, errors);
  EXPECT_GT(errors, 0);
}

TEST_F(CloudIoTest, ReadsAMillionBinaryPointsQuickly) {
  const Matrix3Xd points = RandomFloatPoints(1'000'000, 6);
  for (const auto& write : {WritePly, WritePcd}) {
    const auto path = dir_ / (write == WritePly ? "big.ply" : "big.pcd");
    write(path, points, true);
    const auto start = std::chrono::steady_clock::now();
    const PointCloudFile read = ReadPointCloud(path);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("%s: 1e6 points read in %.3f s\n", read.format.c_str(), seconds);
    ASSERT_EQ(read.points.cols(), points.cols());
    EXPECT_EQ(read.points, points);
#ifndef RMPMARL_UNDER_SANITIZER
    EXPECT_LT(seconds, 1.0) << read.format;
#endif
  }
}

}  // namespace
}  // namespace rmpmarl::control
