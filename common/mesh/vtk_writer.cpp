#include "common/mesh/vtk_writer.h"

#include <fstream>
#include <limits>
#include <ostream>

#include "common/core/error.h"

namespace nsim {
namespace {

constexpr int kVtkTetra = 10;

void CheckField(const VtkField& f, Eigen::Index columns, const char* kind) {
  NSIM_CHECK(!f.name.empty() && f.name.find_first_of(" \t\r\n") == std::string::npos,
             "VTK field name must be non-empty without whitespace, got '", f.name, "'");
  NSIM_CHECK(f.values.rows() == 1 || f.values.rows() == 3, "VTK field '", f.name,
             "' must have 1 or 3 rows, got ", f.values.rows());
  NSIM_CHECK(f.values.cols() == columns, "VTK ", kind, " field '", f.name, "' has ",
             f.values.cols(), " columns, expected ", columns);
}

void WriteHeader(std::ostream& out, const std::string& title, const char* dataset) {
  // the title line is limited to 256 characters and must be a single line
  std::string line = title.substr(0, 255);
  for (char& c : line)
    if (c == '\n' || c == '\r') c = ' ';
  out << "# vtk DataFile Version 3.0\n" << line << "\nASCII\nDATASET " << dataset << "\n";
  out.precision(std::numeric_limits<double>::max_digits10);
}

void WritePoints(std::ostream& out, const Eigen::Matrix3Xd& x, const std::vector<int>* subset) {
  const Eigen::Index n = subset ? static_cast<Eigen::Index>(subset->size()) : x.cols();
  out << "POINTS " << n << " double\n";
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index c = subset ? (*subset)[i] : i;
    out << x(0, c) << " " << x(1, c) << " " << x(2, c) << "\n";
  }
}

// one data block (POINT_DATA or CELL_DATA); `subset` selects columns (nullptr: all)
void WriteFields(std::ostream& out, const char* block, const std::vector<VtkField>& fields,
                 Eigen::Index count, const std::vector<int>* subset) {
  if (fields.empty()) return;
  out << block << " " << count << "\n";
  for (const VtkField& f : fields) {
    if (f.values.rows() == 1) {
      out << "SCALARS " << f.name << " double 1\nLOOKUP_TABLE default\n";
    } else {
      out << "VECTORS " << f.name << " double\n";
    }
    for (Eigen::Index i = 0; i < count; ++i) {
      const Eigen::Index c = subset ? (*subset)[i] : i;
      for (Eigen::Index r = 0; r < f.values.rows(); ++r) out << (r ? " " : "") << f.values(r, c);
      out << "\n";
    }
  }
}

std::ofstream OpenForWriting(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw InputError(Str(path, ": cannot open the VTK file for writing"));
  return out;
}

void Finish(std::ostream& out, const std::string& path) {
  out.flush();
  if (!out) throw InputError(Str(path, ": error while writing the VTK file"));
}

}  // namespace

void WriteVtkTetMesh(std::ostream& out, const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                     const VtkData& data, const std::string& title) {
  NSIM_CHECK(x.cols() == mesh.num_nodes(), "positions have ", x.cols(), " columns for ",
             mesh.num_nodes(), " nodes");
  for (const auto& f : data.point_data) CheckField(f, mesh.num_nodes(), "point");
  for (const auto& f : data.cell_data) CheckField(f, mesh.num_tets(), "cell");
  WriteHeader(out, title, "UNSTRUCTURED_GRID");
  WritePoints(out, x, nullptr);
  out << "CELLS " << mesh.num_tets() << " " << 5 * mesh.num_tets() << "\n";
  for (const auto& t : mesh.tets)
    out << "4 " << t[0] << " " << t[1] << " " << t[2] << " " << t[3] << "\n";
  out << "CELL_TYPES " << mesh.num_tets() << "\n";
  for (int e = 0; e < mesh.num_tets(); ++e) out << kVtkTetra << "\n";
  WriteFields(out, "POINT_DATA", data.point_data, mesh.num_nodes(), nullptr);
  WriteFields(out, "CELL_DATA", data.cell_data, mesh.num_tets(), nullptr);
}

void WriteVtkTetMesh(const std::string& path, const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                     const VtkData& data, const std::string& title) {
  std::ofstream out = OpenForWriting(path);
  WriteVtkTetMesh(out, mesh, x, data, title);
  Finish(out, path);
}

void WriteVtkSurface(std::ostream& out, const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                     const VtkData& data, const std::string& title) {
  NSIM_CHECK(x.cols() == mesh.num_nodes(), "positions have ", x.cols(), " columns for ",
             mesh.num_nodes(), " nodes");
  const auto num_tris = static_cast<Eigen::Index>(mesh.surface.size());
  for (const auto& f : data.point_data) CheckField(f, mesh.num_nodes(), "point");
  for (const auto& f : data.cell_data) CheckField(f, num_tris, "cell");
  // surface nodes, ascending, and the renumbering
  std::vector<int> local(mesh.num_nodes(), -1);
  for (const auto& f : mesh.surface)
    for (int k = 0; k < 3; ++k) local[f[k]] = 0;
  std::vector<int> nodes;
  for (int i = 0; i < mesh.num_nodes(); ++i)
    if (local[i] == 0) {
      local[i] = static_cast<int>(nodes.size());
      nodes.push_back(i);
    }
  WriteHeader(out, title, "POLYDATA");
  WritePoints(out, x, &nodes);
  out << "POLYGONS " << num_tris << " " << 4 * num_tris << "\n";
  for (const auto& f : mesh.surface)
    out << "3 " << local[f[0]] << " " << local[f[1]] << " " << local[f[2]] << "\n";
  WriteFields(out, "POINT_DATA", data.point_data, static_cast<Eigen::Index>(nodes.size()), &nodes);
  WriteFields(out, "CELL_DATA", data.cell_data, num_tris, nullptr);
}

void WriteVtkSurface(const std::string& path, const TetMesh& mesh, const Eigen::Matrix3Xd& x,
                     const VtkData& data, const std::string& title) {
  std::ofstream out = OpenForWriting(path);
  WriteVtkSurface(out, mesh, x, data, title);
  Finish(out, path);
}

void WriteVtkPolyline(std::ostream& out, const Eigen::Matrix3Xd& points, const VtkData& data,
                      const std::string& title) {
  NSIM_CHECK(points.cols() >= 1, "a polyline needs at least one point");
  for (const auto& f : data.point_data) CheckField(f, points.cols(), "point");
  for (const auto& f : data.cell_data) CheckField(f, 1, "cell");
  WriteHeader(out, title, "POLYDATA");
  WritePoints(out, points, nullptr);
  out << "LINES 1 " << points.cols() + 1 << "\n" << points.cols();
  for (Eigen::Index i = 0; i < points.cols(); ++i) out << " " << i;
  out << "\n";
  WriteFields(out, "POINT_DATA", data.point_data, points.cols(), nullptr);
  WriteFields(out, "CELL_DATA", data.cell_data, 1, nullptr);
}

void WriteVtkPolyline(const std::string& path, const Eigen::Matrix3Xd& points, const VtkData& data,
                      const std::string& title) {
  std::ofstream out = OpenForWriting(path);
  WriteVtkPolyline(out, points, data, title);
  Finish(out, path);
}

}  // namespace nsim
