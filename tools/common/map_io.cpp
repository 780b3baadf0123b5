#include "common/map_io.hpp"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <unordered_set>

#include "common/text_io.hpp"
#include "dynamap/map/occupancy_map.hpp"

namespace dynamap::tools {
namespace {

// PLY scalar types and their sizes in bytes (0: not a PLY scalar type).
std::size_t ply_type_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32")
    return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

// One little-endian binary scalar as double (the host is little-endian: tools run on x86/arm64).
double ply_binary_value(const char* p, const std::string& t) {
  auto get = [p](auto v) {
    std::memcpy(&v, p, sizeof(v));
    return static_cast<double>(v);
  };
  if (t == "char" || t == "int8") return get(std::int8_t{});
  if (t == "uchar" || t == "uint8") return get(std::uint8_t{});
  if (t == "short" || t == "int16") return get(std::int16_t{});
  if (t == "ushort" || t == "uint16") return get(std::uint16_t{});
  if (t == "int" || t == "int32") return get(std::int32_t{});
  if (t == "uint" || t == "uint32") return get(std::uint32_t{});
  if (t == "float" || t == "float32") return get(float{});
  return get(double{});
}

struct PlyHeader {
  bool binary = false;
  std::size_t vertices = 0;
  std::vector<std::string> types;  // vertex properties, in order
  int x = -1, y = -1, z = -1, probability = -1;
  std::size_t record_bytes = 0;
  std::size_t lines = 0;  // header lines including end_header
};

PlyHeader read_ply_header(std::istream& in, const std::string& path) {
  PlyHeader h;
  std::string line;
  bool in_vertex = false, format_seen = false;
  while (std::getline(in, line)) {
    const TextLocation at{path, ++h.lines};
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto f = split_ws(line);
    if (h.lines == 1) {
      if (line != "ply") fail_at(at, "not a PLY file (first line is not 'ply')");
      continue;
    }
    if (f.empty() || f[0] == "comment" || f[0] == "obj_info") continue;
    if (f[0] == "end_header") {
      if (!format_seen) fail_at(at, "no 'format' line in the header");
      if (h.x < 0 || h.y < 0 || h.z < 0 || h.probability < 0)
        fail_at(at, "the vertex element needs float properties x, y, z and probability");
      return h;
    }
    if (f[0] == "format") {
      if (f.size() < 2 || (f[1] != "ascii" && f[1] != "binary_little_endian"))
        fail_at(at, "only 'format ascii' and 'format binary_little_endian' are read");
      h.binary = f[1] == "binary_little_endian";
      format_seen = true;
    } else if (f[0] == "element") {
      if (f.size() < 3) fail_at(at, "expected 'element NAME COUNT'");
      if (h.vertices > 0 || in_vertex) fail_at(at, "only one element (vertex) is read");
      if (f[1] != "vertex") fail_at(at, "only the element 'vertex' is read, not '" + f[1] + "'");
      const long long n = parse_int(f[2], at, "vertex count");
      if (n < 0) fail_at(at, "negative vertex count");
      h.vertices = static_cast<std::size_t>(n);
      in_vertex = true;
    } else if (f[0] == "property") {
      if (!in_vertex) fail_at(at, "property before 'element vertex'");
      if (f.size() != 3 || ply_type_size(f[1]) == 0)
        fail_at(at, "expected 'property TYPE NAME' with a scalar type (lists are not read)");
      const int index = static_cast<int>(h.types.size());
      if (f[2] == "x") h.x = index;
      if (f[2] == "y") h.y = index;
      if (f[2] == "z") h.z = index;
      if (f[2] == "probability") h.probability = index;
      h.types.push_back(f[1]);
      h.record_bytes += ply_type_size(f[1]);
    } else {
      fail_at(at, "unexpected header line '" + line + "'");
    }
  }
  throw ToolError(path + ": the header has no 'end_header' line");
}

MapVoxel voxel_of(const std::vector<double>& v, const PlyHeader& h) {
  MapVoxel m;
  m.centre = Eigen::Vector3d(v[static_cast<std::size_t>(h.x)], v[static_cast<std::size_t>(h.y)],
                             v[static_cast<std::size_t>(h.z)])
                 .cast<float>();
  m.probability = static_cast<float>(v[static_cast<std::size_t>(h.probability)]);
  return m;
}

void check_voxel(const MapVoxel& m, const std::string& where) {
  if (!m.centre.allFinite() || !(m.probability >= 0.f && m.probability <= 1.f))
    throw ToolError(where + ": non-finite coordinate or probability outside [0, 1]");
}

}  // namespace

void write_map_ply(const std::string& path, const std::vector<MapVoxel>& voxels,
                   const std::string& comment) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw ToolError(path + ": cannot create file");
  out << "ply\nformat binary_little_endian 1.0\n"
      << "comment " << comment << "\n"
      << "element vertex " << voxels.size() << "\n"
      << "property float x\nproperty float y\nproperty float z\nproperty float probability\n"
      << "end_header\n";
  for (const MapVoxel& m : voxels) {
    const float rec[4] = {m.centre.x(), m.centre.y(), m.centre.z(), m.probability};
    out.write(reinterpret_cast<const char*>(rec), sizeof(rec));
  }
  if (!out) throw ToolError(path + ": write error");
}

std::vector<MapVoxel> read_map_ply(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ToolError(path + ": cannot open (a replay writes map.ply at its end)");
  const PlyHeader h = read_ply_header(in, path);
  std::vector<MapVoxel> voxels;
  voxels.reserve(h.vertices);
  std::vector<double> values(h.types.size());
  if (h.binary) {
    std::vector<char> rec(h.record_bytes);
    for (std::size_t i = 0; i < h.vertices; ++i) {
      if (!in.read(rec.data(), static_cast<std::streamsize>(rec.size())))
        throw ToolError(path + ": file ends at vertex " + std::to_string(i) + " of " +
                        std::to_string(h.vertices));
      std::size_t offset = 0;
      for (std::size_t k = 0; k < h.types.size(); ++k) {
        values[k] = ply_binary_value(rec.data() + offset, h.types[k]);
        offset += ply_type_size(h.types[k]);
      }
      voxels.push_back(voxel_of(values, h));
      check_voxel(voxels.back(), path + ": vertex " + std::to_string(i));
    }
    return voxels;
  }
  std::string line;
  std::size_t line_no = h.lines;
  while (voxels.size() < h.vertices && std::getline(in, line)) {
    const TextLocation at{path, ++line_no};
    const auto f = split_ws(line);
    if (f.empty()) continue;
    if (f.size() < h.types.size()) fail_at(at, "too few values for the vertex properties");
    for (std::size_t k = 0; k < h.types.size(); ++k) values[k] = parse_double(f[k], at, "value");
    voxels.push_back(voxel_of(values, h));
    check_voxel(voxels.back(), at.str());
  }
  if (voxels.size() < h.vertices)
    throw ToolError(path + ": file ends after " + std::to_string(voxels.size()) + " of " +
                    std::to_string(h.vertices) + " vertices");
  return voxels;
}

ModelHoleCounts count_model_holes(const OccupancyMap& map, const std::vector<MapVoxel>& model,
                                  const Eigen::Vector3f& camera, const Eigen::Vector3f& half_extent,
                                  float max_depth) {
  ModelHoleCounts n;
  std::unordered_set<OccupancyMap::VoxelKey> seen;
  const float tolerance = 0.25f * map.resolution();
  for (const MapVoxel& m : model) {
    if (((m.centre - camera).array().abs() > half_extent.array()).any()) continue;
    const OccupancyMap::VoxelKey key = map.key_of(m.centre);
    if (!seen.insert(key).second) continue;  // a finer model: each map voxel once
    const Eigen::Vector3f c = map.center_of(key);
    if (((c - m.centre).array().abs() > tolerance).any()) ++n.misaligned;
    const Occupancy s = map.state(key);
    const bool near = (c - camera).norm() <= max_depth;
    for (ModelHoleCounts::States* t : {&n.region, near ? &n.depth : nullptr}) {
      if (t == nullptr) continue;
      ++t->voxels;
      t->occupied += s == Occupancy::kOccupied ? 1 : 0;
      t->free += s == Occupancy::kFree ? 1 : 0;
      t->unknown += s == Occupancy::kUnknown ? 1 : 0;
    }
    if (s == Occupancy::kFree) n.holes.push_back(c);
  }
  return n;
}

double MapSummary::number(const std::string& key, double fallback) const {
  const auto it = values.find(key);
  if (it == values.end()) return fallback;
  if (it->second.size() != 1)
    throw ToolError(path + ": key '" + key + "' should have exactly one value");
  return parse_double(it->second[0], TextLocation{path, 0}, key.c_str());
}

void write_map_summary(const std::string& path,
                       const std::vector<std::pair<std::string, std::string>>& entries) {
  std::ofstream out(path);
  if (!out) throw ToolError(path + ": cannot create file");
  out << "# dynamap-replay: the final occupancy map (docs/tools.md); key value\n";
  for (const auto& [key, value] : entries) out << key << " " << value << "\n";
  if (!out) throw ToolError(path + ": write error");
}

MapSummary read_map_summary(const std::string& path) {
  MapSummary s;
  s.path = path;
  const auto lines = read_lines(path);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string body = strip_comment(lines[i]);
    if (body.empty()) continue;
    auto f = split_ws(body);
    const std::string key = f[0];
    if (s.values.count(key) != 0) fail_at(TextLocation{path, i + 1}, "key '" + key + "' twice");
    f.erase(f.begin());
    s.values[key] = f;
  }
  return s;
}

}  // namespace dynamap::tools
