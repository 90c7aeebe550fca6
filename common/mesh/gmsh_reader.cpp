#include "common/mesh/gmsh_reader.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <istream>
#include <limits>
#include <map>
#include <sstream>
#include <unordered_map>

#include "common/core/error.h"
#include "common/core/input_file.h"

namespace nsim {
namespace {

constexpr int kTypeTriangle = 2;
constexpr int kTypeTet = 4;

/// Reads a stream line by line, splitting each line into whitespace-separated tokens.
class LineReader {
 public:
  /// `size`: the stream's length in bytes, or -1 when unknown (then counts are not bounded).
  LineReader(std::istream& in, std::string source, long long size)
      : in_(in), source_(std::move(source)), size_(size) {}

  /// Advances to the next line (blank lines included); false at the end of the stream.
  bool Next() {
    if (!std::getline(in_, line_)) return false;
    ++number_;
    consumed_ += static_cast<long long>(line_.size()) + 1;
    if (!line_.empty() && line_.back() == '\r') line_.pop_back();
    tokens_.clear();
    std::string::size_type pos = 0;
    while (true) {
      const auto begin = line_.find_first_not_of(" \t", pos);
      if (begin == std::string::npos) break;
      auto end = line_.find_first_of(" \t", begin);
      if (end == std::string::npos) end = line_.size();
      tokens_.push_back(line_.substr(begin, end - begin));
      pos = end;
    }
    return true;
  }

  /// Advances to the next non-blank line; throws `expected` at the end of the stream.
  void NextNonBlank(const std::string& expected) {
    do {
      if (!Next()) throw Error(Str("unexpected end of file: expected ", expected));
    } while (tokens_.empty());
  }

  InputError Error(const std::string& what) const {
    return InputError(Str(source_, ":", std::max(number_, 1L), ": ", what));  // line 1 if empty
  }

  /// Checks the line has exactly `n` tokens (or at least `n` when `at_least`).
  void ExpectTokens(size_t n, const std::string& expected, bool at_least = false) const {
    if (tokens_.size() == n || (at_least && tokens_.size() > n)) return;
    throw Error(Str("expected ", expected, " (", at_least ? "at least " : "", n, " values), got ",
                    tokens_.size(), " values: '", line_, "'"));
  }

  long long Integer(size_t i, const char* what) const {
    const std::string& s = tokens_.at(i);
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(s.c_str(), &end, 10);
    if (end == s.c_str() || *end != '\0' || errno == ERANGE)
      throw Error(Str("expected ", what, " (an integer), got '", s, "'"));
    return v;
  }

  long long NonNegative(size_t i, const char* what) const {
    const long long v = Integer(i, what);
    if (v < 0) throw Error(Str("expected ", what, " >= 0, got ", v));
    return v;
  }

  double Real(size_t i, const char* what) const {
    const std::string& s = tokens_.at(i);
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
      throw Error(Str("expected ", what, " (a finite number), got '", s, "'"));
    return v;
  }

  /// Checks that a header's `count` of `what` fits in the rest of the file, each taking at
  /// least `min_bytes` bytes, before anything is allocated for them: a header announcing 1e12
  /// nodes in a small file is an error at its line, not a bad_alloc.
  void CheckCount(long long count, int min_bytes, const char* what) const {
    if (count > std::numeric_limits<int>::max())
      throw Error(Str("the header announces ", count, " ", what, ", more than the ",
                      std::numeric_limits<int>::max(), " a mesh can index"));
    if (size_ < 0) return;
    const long long room = std::max(0LL, size_ - consumed_) / min_bytes;
    if (count > room)
      throw Error(Str("the header announces ", count, " ", what, ", more than the rest of the file (",
                      std::max(0LL, size_ - consumed_), " bytes) can hold (at least ", min_bytes,
                      " bytes each)"));
  }

  const std::vector<std::string>& tokens() const { return tokens_; }
  const std::string& line() const { return line_; }
  long number() const { return number_; }
  const std::string& source() const { return source_; }

 private:
  std::istream& in_;
  std::string source_;
  std::string line_;
  std::vector<std::string> tokens_;
  long number_ = 0;
  long long size_ = -1, consumed_ = 0;
};

// the shortest lines of a section, for LineReader::CheckCount: a node is "t x y z\n" (v2) or
// "t\n" + "x y z\n" (v4), an element line at least "a b c\n" (v2) or "a\n" (v4, an ignored
// type), a block header "a b c d\n"
constexpr int kMinNodeBytes = 8;
constexpr int kMinElementBytes2 = 6;
constexpr int kMinElementBytes4 = 2;
constexpr int kMinBlockBytes = 8;

struct RawNode {
  Eigen::Vector3d x;
  long line;
};

struct RawElement {
  int type;  // kTypeTet or kTypeTriangle
  int entity;
  long line;
  std::array<long long, 4> tags;  // node tags; 3 used for triangles
};

/// Everything parsed from the sections, before node tags are resolved.
struct RawMesh {
  int major = 0;  // 2 or 4
  std::string version;
  std::vector<long long> node_tags;
  std::vector<RawNode> nodes;
  std::unordered_map<long long, int> node_index;  // tag -> position in nodes
  std::vector<RawElement> elements;
  std::map<int, long> ignored_types;  // element type -> count
  long nodes_line = 0, elements_line = 0;
};

std::string ElementTypeName(int type) {
  switch (type) {
    case 1:
      return "2-node line";
    case 2:
      return "3-node triangle";
    case 3:
      return "4-node quadrangle";
    case 4:
      return "4-node tetrahedron";
    case 5:
      return "8-node hexahedron";
    case 6:
      return "6-node prism";
    case 7:
      return "5-node pyramid";
    case 8:
      return "3-node line";
    case 9:
      return "6-node triangle";
    case 11:
      return "10-node tetrahedron";
    case 15:
      return "1-node point";
    default:
      return Str("type ", type);
  }
}

void ExpectEnd(LineReader& r, const std::string& end) {
  r.NextNonBlank(end);
  if (r.tokens()[0] != end) throw r.Error(Str("expected ", end, ", got '", r.line(), "'"));
}

void ParseMeshFormat(LineReader& r, RawMesh& m) {
  r.NextNonBlank("the format line 'version file-type data-size'");
  r.ExpectTokens(3, "the format line 'version file-type data-size'");
  const std::string& version = r.tokens()[0];
  if (version == "2" || version == "2.0" || version == "2.1" || version == "2.2") {
    m.major = 2;
  } else if (version == "4.1") {
    m.major = 4;
  } else {
    throw r.Error(Str("unsupported MSH format version '", version,
                      "': expected 2.2 or 4.1 (write with gmsh -format msh41 or msh22)"));
  }
  m.version = version;
  if (r.tokens()[1] != "0") {
    throw r.Error(Str("file-type '", r.tokens()[1],
                      "': binary MSH files are not supported, "
                      "expected ASCII (file-type 0; write with Mesh.Binary = 0)"));
  }
  const long long data_size = r.Integer(2, "the data size");
  if (data_size != 8 && data_size != 4)
    throw r.Error(Str("expected data-size 8 (or 4), got ", data_size));
  ExpectEnd(r, "$EndMeshFormat");
}

void AddNode(LineReader& r, RawMesh& m, long long tag, const Eigen::Vector3d& x, long tag_line) {
  if (tag <= 0) throw r.Error(Str("expected a node tag > 0, got ", tag));
  const auto [it, inserted] = m.node_index.emplace(tag, static_cast<int>(m.nodes.size()));
  if (!inserted) {
    throw r.Error(
        Str("duplicate node tag ", tag, " (first defined at line ", m.nodes[it->second].line, ")"));
  }
  m.node_tags.push_back(tag);
  m.nodes.push_back({x, tag_line});
}

Eigen::Vector3d ReadXyz(const LineReader& r, size_t first) {
  return {r.Real(first, "node x"), r.Real(first + 1, "node y"), r.Real(first + 2, "node z")};
}

void ParseNodes2(LineReader& r, RawMesh& m) {
  r.NextNonBlank("the number of nodes");
  r.ExpectTokens(1, "the number of nodes");
  const long long n = r.NonNegative(0, "the number of nodes");
  r.CheckCount(n, kMinNodeBytes, "nodes");
  m.nodes.reserve(n);
  for (long long i = 0; i < n; ++i) {
    r.NextNonBlank(Str("node ", i + 1, " of ", n, " 'tag x y z'"));
    if (r.tokens()[0][0] == '$')
      throw r.Error(Str("expected ", n, " nodes, got ", i, " before '", r.line(), "'"));
    r.ExpectTokens(4, "a node line 'tag x y z'");
    AddNode(r, m, r.Integer(0, "a node tag"), ReadXyz(r, 1), r.number());
  }
  ExpectEnd(r, "$EndNodes");
}

void ParseNodes4(LineReader& r, RawMesh& m) {
  r.NextNonBlank("the nodes header 'numEntityBlocks numNodes minNodeTag maxNodeTag'");
  r.ExpectTokens(4, "the nodes header 'numEntityBlocks numNodes minNodeTag maxNodeTag'");
  const long long blocks = r.NonNegative(0, "the number of node blocks");
  const long long total = r.NonNegative(1, "the number of nodes");
  r.CheckCount(blocks, kMinBlockBytes, "node blocks");
  r.CheckCount(total, kMinNodeBytes, "nodes");
  m.nodes.reserve(total);
  for (long long b = 0; b < blocks; ++b) {
    r.NextNonBlank("a node block header 'entityDim entityTag parametric numNodesInBlock'");
    if (r.tokens()[0][0] == '$')
      throw r.Error(Str("expected ", blocks, " node blocks, got ", b, " before '", r.line(), "'"));
    r.ExpectTokens(4, "a node block header 'entityDim entityTag parametric numNodesInBlock'");
    const long long dim = r.Integer(0, "the entity dimension");
    if (dim < 0 || dim > 3) throw r.Error(Str("expected an entity dimension 0..3, got ", dim));
    const long long parametric = r.Integer(2, "the parametric flag");
    if (parametric != 0 && parametric != 1)
      throw r.Error(Str("expected a parametric flag 0 or 1, got ", parametric));
    const long long count = r.NonNegative(3, "the number of nodes in the block");
    if (static_cast<long long>(m.nodes.size()) + count > total)
      throw r.Error(Str("node blocks hold more nodes than the header's ", total));
    r.CheckCount(count, kMinNodeBytes, "nodes in the block");
    std::vector<std::pair<long long, long>> tags;  // (tag, line)
    tags.reserve(count);
    for (long long i = 0; i < count; ++i) {
      r.NextNonBlank("a node tag");
      r.ExpectTokens(1, "a node tag (one per line)");
      tags.emplace_back(r.Integer(0, "a node tag"), r.number());
    }
    const size_t values = 3 + (parametric ? static_cast<size_t>(dim) : 0);
    for (long long i = 0; i < count; ++i) {
      r.NextNonBlank("node coordinates 'x y z'");
      r.ExpectTokens(values, parametric ? "node coordinates 'x y z' and parameters"
                                        : "node coordinates 'x y z'");
      AddNode(r, m, tags[i].first, ReadXyz(r, 0), tags[i].second);
    }
  }
  if (static_cast<long long>(m.nodes.size()) != total)
    throw r.Error(
        Str("the nodes header announces ", total, " nodes, the blocks hold ", m.nodes.size()));
  ExpectEnd(r, "$EndNodes");
}

int NodesOf(int type) { return type == kTypeTet ? 4 : 3; }

void ParseElements2(LineReader& r, RawMesh& m) {
  r.NextNonBlank("the number of elements");
  r.ExpectTokens(1, "the number of elements");
  const long long n = r.NonNegative(0, "the number of elements");
  r.CheckCount(n, kMinElementBytes2, "elements");
  for (long long i = 0; i < n; ++i) {
    r.NextNonBlank(Str("element ", i + 1, " of ", n));
    if (r.tokens()[0][0] == '$')
      throw r.Error(Str("expected ", n, " elements, got ", i, " before '", r.line(), "'"));
    r.ExpectTokens(3, "an element line 'tag type numTags tags... nodes...'", true);
    r.Integer(0, "an element tag");
    const long long type = r.Integer(1, "an element type");
    const long long num_tags = r.NonNegative(2, "the number of element tags");
    if (type != kTypeTet && type != kTypeTriangle) {
      ++m.ignored_types[static_cast<int>(type)];
      continue;
    }
    const int nodes = NodesOf(static_cast<int>(type));
    r.ExpectTokens(3 + num_tags + nodes, Str("a ", ElementTypeName(static_cast<int>(type)),
                                             " line with ", num_tags, " tags"));
    RawElement e{static_cast<int>(type), 0, r.number(), {0, 0, 0, 0}};
    if (num_tags >= 2) e.entity = static_cast<int>(r.Integer(4, "the elementary entity tag"));
    for (int k = 0; k < nodes; ++k) e.tags[k] = r.Integer(3 + num_tags + k, "a node tag");
    m.elements.push_back(e);
  }
  ExpectEnd(r, "$EndElements");
}

void ParseElements4(LineReader& r, RawMesh& m) {
  r.NextNonBlank("the elements header 'numEntityBlocks numElements minTag maxTag'");
  r.ExpectTokens(4, "the elements header 'numEntityBlocks numElements minTag maxTag'");
  const long long blocks = r.NonNegative(0, "the number of element blocks");
  const long long total = r.NonNegative(1, "the number of elements");
  r.CheckCount(blocks, kMinBlockBytes, "element blocks");
  r.CheckCount(total, kMinElementBytes4, "elements");
  long long seen = 0;
  for (long long b = 0; b < blocks; ++b) {
    r.NextNonBlank("an element block header 'entityDim entityTag elementType numElementsInBlock'");
    if (r.tokens()[0][0] == '$')
      throw r.Error(
          Str("expected ", blocks, " element blocks, got ", b, " before '", r.line(), "'"));
    r.ExpectTokens(4,
                   "an element block header 'entityDim entityTag elementType numElementsInBlock'");
    const int entity = static_cast<int>(r.Integer(1, "the entity tag"));
    const long long type = r.Integer(2, "an element type");
    const long long count = r.NonNegative(3, "the number of elements in the block");
    seen += count;
    if (seen > total)
      throw r.Error(Str("element blocks hold more elements than the header's ", total));
    const bool keep = type == kTypeTet || type == kTypeTriangle;
    if (!keep) m.ignored_types[static_cast<int>(type)] += count;
    for (long long i = 0; i < count; ++i) {
      r.NextNonBlank(Str("element ", i + 1, " of ", count, " in the block"));
      if (r.tokens()[0][0] == '$')
        throw r.Error(
            Str("expected ", count, " elements in the block, got ", i, " before '", r.line(), "'"));
      if (!keep) continue;
      const int nodes = NodesOf(static_cast<int>(type));
      r.ExpectTokens(1 + nodes,
                     Str("a ", ElementTypeName(static_cast<int>(type)), " line 'tag nodes...'"));
      r.Integer(0, "an element tag");
      RawElement e{static_cast<int>(type), entity, r.number(), {0, 0, 0, 0}};
      for (int k = 0; k < nodes; ++k) e.tags[k] = r.Integer(1 + k, "a node tag");
      m.elements.push_back(e);
    }
  }
  if (seen != total)
    throw r.Error(
        Str("the elements header announces ", total, " elements, the blocks hold ", seen));
  ExpectEnd(r, "$EndElements");
}

void SkipSection(LineReader& r, const std::string name) {  // by value: tokens change
  const long start = r.number();
  const std::string end = "$End" + name.substr(1);
  while (r.Next()) {
    if (!r.tokens().empty() && r.tokens()[0] == end) return;
  }
  throw r.Error(
      Str("unexpected end of file: section ", name, " opened at line ", start, " has no ", end));
}

RawMesh ParseSections(LineReader& r) {
  RawMesh m;
  long format_line = 0;
  while (r.Next()) {
    if (r.tokens().empty()) continue;
    const std::string head = r.tokens()[0];  // a copy: reading on replaces the tokens
    if (head[0] != '$') {
      throw r.Error(Str("expected a section header such as $MeshFormat, $Nodes or $Elements, got '",
                        r.line(), "'"));
    }
    if (head == "$MeshFormat") {
      if (format_line)
        throw r.Error(Str("duplicate $MeshFormat (first at line ", format_line, ")"));
      format_line = r.number();
      ParseMeshFormat(r, m);
      continue;
    }
    if (!format_line && head != "$Comments") {
      throw r.Error(Str("expected $MeshFormat as the first section, got '", head, "'"));
    }
    if (head == "$Nodes") {
      if (m.nodes_line) throw r.Error(Str("duplicate $Nodes (first at line ", m.nodes_line, ")"));
      m.nodes_line = r.number();
      m.major == 2 ? ParseNodes2(r, m) : ParseNodes4(r, m);
    } else if (head == "$Elements") {
      if (m.elements_line)
        throw r.Error(Str("duplicate $Elements (first at line ", m.elements_line, ")"));
      m.elements_line = r.number();
      m.major == 2 ? ParseElements2(r, m) : ParseElements4(r, m);
    } else if (head.compare(0, 4, "$End") == 0) {
      throw r.Error(Str("'", head, "' closes no open section"));
    } else {
      SkipSection(r, head);  // $PhysicalNames, $Entities, $NodeData, ...
    }
  }
  if (!format_line)
    throw r.Error("end of file: no $MeshFormat section, this is not a Gmsh .msh file");
  if (!m.nodes_line) throw r.Error("end of file: no $Nodes section");
  if (!m.elements_line) throw r.Error("end of file: no $Elements section");
  return m;
}

}  // namespace

TetMesh ParseGmshMesh(std::istream& in, const std::string& source, const GmshReadOptions& options,
                      GmshFileInfo* info) {
  // the stream's length bounds the counts its headers may announce
  long long size = -1;
  const std::istream::pos_type start = in.tellg();
  if (start != std::istream::pos_type(-1) && in.seekg(0, std::ios::end)) {
    size = static_cast<long long>(in.tellg() - start);
    in.seekg(start);
  }
  in.clear();
  LineReader reader(in, source, size);
  RawMesh raw = ParseSections(reader);
  auto fail = [&](long line, const std::string& what) {
    return InputError(Str(source, ":", line, ": ", what));
  };

  // resolve node tags; keep the nodes used by tetrahedra, in file order
  std::vector<int> used(raw.nodes.size(), 0);
  long num_tets = 0;
  for (RawElement& e : raw.elements) {
    for (int k = 0; k < NodesOf(e.type); ++k) {
      const auto it = raw.node_index.find(e.tags[k]);
      if (it == raw.node_index.end()) {
        throw fail(e.line, Str("unknown node tag ", e.tags[k], " in a ", ElementTypeName(e.type),
                               " (no such node in $Nodes at line ", raw.nodes_line, ")"));
      }
      e.tags[k] = it->second;  // now a position in raw.nodes
      if (e.type == kTypeTet) used[it->second] = 1;
    }
    if (e.type == kTypeTet) ++num_tets;
  }
  if (num_tets == 0) {
    std::string found;
    for (const auto& [type, count] : raw.ignored_types)
      found += Str(found.empty() ? "" : ", ", count, " x ", ElementTypeName(type));
    throw fail(raw.elements_line, Str("expected linear tetrahedra (element type 4), found none",
                                      found.empty() ? std::string() : Str(" (only ", found, ")"),
                                      "; mesh the volume (gmsh -3) with Mesh.ElementOrder = 1"));
  }
  std::vector<int> compact(raw.nodes.size(), -1);
  TetMesh mesh;
  int num_nodes = 0;
  for (size_t i = 0; i < raw.nodes.size(); ++i)
    if (used[i]) compact[i] = num_nodes++;
  mesh.X.resize(3, num_nodes);
  GmshFileInfo local;
  GmshFileInfo& out = info ? *info : local;
  out = GmshFileInfo();
  out.version = raw.version;
  out.node_tags.resize(num_nodes);
  for (size_t i = 0; i < raw.nodes.size(); ++i) {
    if (compact[i] < 0) continue;
    mesh.X.col(compact[i]) = raw.nodes[i].x;
    out.node_tags[compact[i]] = raw.node_tags[i];
  }
  out.num_dropped_nodes = static_cast<int>(raw.nodes.size()) - num_nodes;
  for (const auto& [type, count] : raw.ignored_types)
    out.num_ignored_elements += static_cast<int>(count);

  // tetrahedra: distinct nodes, not degenerate, positively oriented
  mesh.tets.reserve(num_tets);
  for (const RawElement& e : raw.elements) {
    if (e.type != kTypeTet) continue;
    Eigen::Vector4i t;
    for (int k = 0; k < 4; ++k) t[k] = compact[e.tags[k]];
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        if (t[a] == t[b])
          throw fail(e.line, Str("tetrahedron repeats node tag ", out.node_tags[t[a]]));
    const Eigen::Vector3d p[4] = {mesh.X.col(t[0]), mesh.X.col(t[1]), mesh.X.col(t[2]),
                                  mesh.X.col(t[3])};
    double sum_sq = 0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) sum_sq += (p[a] - p[b]).squaredNorm();
    const double l_rms = std::sqrt(sum_sq / 6.0);
    const double volume = SignedTetVolume(p[0], p[1], p[2], p[3]);
    const double normalized = 6.0 * std::sqrt(2.0) * std::abs(volume) / (l_rms * l_rms * l_rms);
    if (!(normalized > options.degenerate_volume_ratio)) {
      throw fail(e.line, Str("degenerate tetrahedron: volume ", volume, " m^3 is ", normalized,
                             " of a regular one with the same edge length; expected more than ",
                             options.degenerate_volume_ratio));
    }
    if (volume < 0) {
      if (!options.reorient_inverted)
        throw fail(e.line, Str("inverted tetrahedron (volume ", volume,
                               " m^3), expected a positive volume"));
      std::swap(t[2], t[3]);
      ++out.num_reoriented_tets;
    }
    mesh.tets.push_back(t);
    out.tet_entities.push_back(e.entity);
    out.tet_lines.push_back(e.line);
  }

  // conformity: every face belongs to one tet (boundary) or two (interior)
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<int, 3>, std::pair<int, int>> faces;  // sorted nodes -> (count, first tet)
  for (int i = 0; i < mesh.num_tets(); ++i) {
    for (const auto& f : kFace) {
      std::array<int, 3> key{mesh.tets[i][f[0]], mesh.tets[i][f[1]], mesh.tets[i][f[2]]};
      std::sort(key.begin(), key.end());
      auto [it, inserted] = faces.try_emplace(key, 0, i);
      if (++it->second.first > 2) {
        throw fail(out.tet_lines[i],
                   Str("non-conforming mesh: a face of this tetrahedron is shared by "
                       "3 or more tetrahedra (also the one at line ",
                       out.tet_lines[it->second.second], ")"));
      }
    }
  }
  mesh.surface = ComputeBoundarySurface(mesh.tets);

  // file triangles: kept when on the mesh, oriented like the boundary when on it
  std::map<std::array<int, 3>, Eigen::Vector3i> boundary;
  for (const auto& f : mesh.surface) {
    std::array<int, 3> key{f[0], f[1], f[2]};
    std::sort(key.begin(), key.end());
    boundary.emplace(key, f);
  }
  for (const RawElement& e : raw.elements) {
    if (e.type != kTypeTriangle) continue;
    Eigen::Vector3i tri(compact[e.tags[0]], compact[e.tags[1]], compact[e.tags[2]]);
    if ((tri.array() < 0).any()) {
      ++out.num_ignored_elements;
      continue;
    }
    std::array<int, 3> key{tri[0], tri[1], tri[2]};
    std::sort(key.begin(), key.end());
    const auto it = boundary.find(key);
    if (it != boundary.end()) {
      tri = it->second;
      ++out.num_boundary_triangles;
    }
    out.triangles.push_back(tri);
    out.triangle_entities.push_back(e.entity);
  }
  return mesh;
}

TetMesh ReadGmshMesh(const std::string& path, const GmshReadOptions& options, GmshFileInfo* info) {
  std::istringstream in(ReadInputFile(path, "mesh file"));
  return ParseGmshMesh(in, path, options, info);
}

TetMesh ReadGmshMesh(const std::string& path) { return ReadGmshMesh(path, GmshReadOptions()); }

}  // namespace nsim
