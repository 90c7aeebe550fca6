#pragma once
// Reading Gmsh .msh files (ASCII, format 2.2 and 4.1) into a TetMesh.
//
// Linear tetrahedra (element type 4) make the mesh; triangles (type 2) are read and reported in
// GmshFileInfo; every other element type (points, lines, quads, ...) is skipped. Node tags may be
// arbitrary positive integers: nodes are renumbered to compact indices 0..#nodes-1 in file
// order, keeping only the nodes that some tetrahedron uses (a free node would make the
// stiffness matrix singular). The boundary surface is always computed from the tetrahedra
// (closed, oriented outward, consistent with the volume), whatever the file's triangles are.
// Errors throw InputError "FILE:LINE: what was expected, what was found".

#include <iosfwd>
#include <string>
#include <vector>

#include "common/mesh/tet_mesh.h"

namespace nsim {

/// How strict the reader is about element shapes.
struct GmshReadOptions {
  /// A tetrahedron whose normalized volume 6 sqrt(2) |V| / l_rms^3 (1 for a regular tetrahedron,
  /// l_rms the root mean square of its 6 edge lengths) is at most this is degenerate and
  /// rejected with an InputError (dimensionless).
  double degenerate_volume_ratio = 1e-8;
  /// Inverted (negative volume) tetrahedra are reoriented when true (counted in
  /// GmshFileInfo::num_reoriented_tets), rejected with an InputError when false.
  bool reorient_inverted = true;
};

/// What the file held besides the mesh itself.
struct GmshFileInfo {
  std::string version;               ///< format version as written in the file: "2.2", "4.1"
  std::vector<long long> node_tags;  ///< file tag of each mesh node, #nodes
  std::vector<int> tet_entities;     ///< elementary entity tag of each tet (0 if none), #tets
  std::vector<long> tet_lines;       ///< file line that defined each tet (1-based), #tets
  /// triangle elements of the file whose nodes all belong to the tet mesh, in compact node
  /// indices; those lying on the boundary are oriented like the boundary (outward)
  std::vector<Eigen::Vector3i> triangles;
  std::vector<int> triangle_entities;  ///< elementary entity tag of each triangle, #triangles
  int num_boundary_triangles = 0;      ///< how many of `triangles` are boundary faces
  int num_reoriented_tets = 0;         ///< inverted tets whose orientation was fixed
  int num_dropped_nodes = 0;           ///< file nodes used by no tetrahedron
  int num_ignored_elements = 0;        ///< elements of other types, or off-mesh triangles
};

/// Reads an ASCII .msh file (format 2.2 or 4.1) with default options. Throws InputError.
TetMesh ReadGmshMesh(const std::string& path);

/// Reads an ASCII .msh file; fills `info` when it is not null. Throws InputError.
TetMesh ReadGmshMesh(const std::string& path, const GmshReadOptions& options,
                     GmshFileInfo* info = nullptr);

/// Same, from a stream; `source` names it in error messages.
TetMesh ParseGmshMesh(std::istream& in, const std::string& source,
                      const GmshReadOptions& options = {}, GmshFileInfo* info = nullptr);

}  // namespace nsim
