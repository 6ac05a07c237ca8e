#pragma once
/// Point cloud files: PLY (Turk, 1994; ascii, binary_little_endian, binary_big_endian) and PCD (the Point Cloud
/// Library's format, v0.7 and the older headers PCL still reads; DATA ascii, binary, binary_compressed).
///
/// Only the positions are read: x, y and z are found by name among the vertex properties (PLY) or fields (PCD), of any
/// numeric type, and converted to double; every other property or field (normals, colours, intensity, padding) is
/// skipped without being parsed. Points with a NaN or infinite coordinate are dropped and counted (PCD's organised
/// clouds mark missing returns with NaN), so the result holds finite points only, in the file's order.
///
/// PLY: the vertex element may carry no list property; elements before it are skipped (in a binary file only
/// elements of scalar properties, whose size the header gives); elements after it (faces) are not read. An ascii
/// PLY holds one element per line.
/// PCD: an absent SIZE/TYPE/COUNT means 4 / F / 1 per field, an absent HEIGHT 1, an absent POINTS WIDTH × HEIGHT (as
/// PCL reads old headers). Binary data is little-endian. binary_compressed is PCL's layout: two uint32 (compressed
/// and uncompressed size), then LZF data that expands to one plane per field (all points' values of the field),
/// fields named "_" (padding) left out. VIEWPOINT is the sensor's pose in the cloud's frame; like PCL, it is not
/// applied to the points, which are returned in the cloud's frame.
///
/// Every problem with a file (missing, truncated, malformed header or number, no x/y/z, more points than the data
/// holds or than CloudReadOptions::max_points) is an InputError whose message starts with the path (and the line,
/// for text) and says what was expected and what was found. The file is read into memory once.
#include <Eigen/Core>
#include <filesystem>
#include <string>

namespace rmpmarl::control {

/// A point cloud as read from a file: positions (3 × N, one column per point, in the file's units and frame).
struct PointCloudFile {
  Eigen::Matrix3Xd points;
  /// "ply ascii", "ply binary_little_endian", "ply binary_big_endian", "pcd ascii", "pcd binary",
  /// "pcd binary_compressed"
  std::string format;
  /// points with a NaN/inf coordinate (PCD's organised clouds mark missing points with NaN): dropped, counted
  long skipped_nonfinite = 0;
};

/// Options of ReadPointCloud.
struct CloudReadOptions {
  /// a file declaring more points than this is refused (InputError naming the count) before anything is allocated;
  /// ≥ 0. 20 M float32 points are 240 MB of file and 480 MB as doubles.
  long max_points = 20'000'000;
};

/// reads a .ply or .pcd file (the extension, in any case, picks the format); throws InputError for any other
/// extension and for every problem with the file.
PointCloudFile ReadPointCloud(const std::filesystem::path& path, const CloudReadOptions& options = {});

/// writes a PLY file of one vertex element with float32 x y z (values rounded to the nearest float):
/// binary_little_endian, or ascii (shortest text that reads back to the same float); throws InputError when the
/// file cannot be written.
void WritePly(const std::filesystem::path& path, const Eigen::Matrix3Xd& points, bool binary = true);

/// writes a PCD v0.7 file with fields x y z (F, SIZE 4), WIDTH N, HEIGHT 1, identity VIEWPOINT: DATA binary, or
/// ascii; throws InputError when the file cannot be written.
void WritePcd(const std::filesystem::path& path, const Eigen::Matrix3Xd& points, bool binary = true);

}  // namespace rmpmarl::control
