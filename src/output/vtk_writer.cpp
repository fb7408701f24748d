#include "output/vtk_writer.hpp"

#include <cstring>
#include <sstream>

#include "output/output_dir.hpp"

namespace biodem::output {
namespace {

std::string base64(const unsigned char* data, std::size_t n) {
  static const char* tbl = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((n + 2) / 3 * 4);
  for (std::size_t i = 0; i < n; i += 3) {
    const unsigned v = (unsigned(data[i]) << 16) | (i + 1 < n ? unsigned(data[i + 1]) << 8 : 0u) |
                       (i + 2 < n ? unsigned(data[i + 2]) : 0u);
    out += tbl[(v >> 18) & 63];
    out += tbl[(v >> 12) & 63];
    out += i + 1 < n ? tbl[(v >> 6) & 63] : '=';
    out += i + 2 < n ? tbl[v & 63] : '=';
  }
  return out;
}

/// VTK "binary" inline encoding: base64 of [UInt32 byte count][raw little-endian data].
template <class T>
std::string encode(const std::vector<T>& v) {
  const std::uint32_t bytes = static_cast<std::uint32_t>(v.size() * sizeof(T));
  std::vector<unsigned char> buf(sizeof(bytes) + bytes);
  std::memcpy(buf.data(), &bytes, sizeof(bytes));
  if (bytes) std::memcpy(buf.data() + sizeof(bytes), v.data(), bytes);
  return base64(buf.data(), buf.size());
}

std::vector<double> flatten(const std::vector<Vec3>& v) {
  std::vector<double> f;
  f.reserve(3 * v.size());
  for (const auto& p : v) {
    f.push_back(p.x);
    f.push_back(p.y);
    f.push_back(p.z);
  }
  return f;
}

}  // namespace

void write_vtu(const std::string& path, const PointCloud& c) {
  const std::size_t n = c.points.size();
  std::ostringstream o;
  o << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
       "header_type=\"UInt32\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\""
    << n << "\" NumberOfCells=\"" << n << "\">\n<PointData Scalars=\"radius\" Vectors=\"velocity\">\n";
  for (const auto& [name, v] : c.scalars)
    o << "<DataArray type=\"Float64\" Name=\"" << name << "\" format=\"binary\">" << encode(v) << "</DataArray>\n";
  for (const auto& [name, v] : c.vectors)
    o << "<DataArray type=\"Float64\" Name=\"" << name << "\" NumberOfComponents=\"3\" format=\"binary\">"
      << encode(flatten(v)) << "</DataArray>\n";
  for (const auto& [name, v] : c.ints)
    o << "<DataArray type=\"Int64\" Name=\"" << name << "\" format=\"binary\">" << encode(v) << "</DataArray>\n";
  for (const auto& [name, v] : c.quats) {
    std::vector<double> f;
    for (const auto& q : v) f.insert(f.end(), q.begin(), q.end());
    o << "<DataArray type=\"Float64\" Name=\"" << name << "\" NumberOfComponents=\"4\" format=\"binary\">"
      << encode(f) << "</DataArray>\n";
  }
  o << "</PointData>\n<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"binary\">"
    << encode(flatten(c.points)) << "</DataArray>\n</Points>\n<Cells>\n";
  std::vector<std::int64_t> conn(n), offs(n);
  std::vector<std::uint8_t> types(n, 1);  // VTK_VERTEX
  for (std::size_t i = 0; i < n; ++i) {
    conn[i] = static_cast<std::int64_t>(i);
    offs[i] = static_cast<std::int64_t>(i + 1);
  }
  o << "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"binary\">" << encode(conn) << "</DataArray>\n"
    << "<DataArray type=\"Int64\" Name=\"offsets\" format=\"binary\">" << encode(offs) << "</DataArray>\n"
    << "<DataArray type=\"UInt8\" Name=\"types\" format=\"binary\">" << encode(types) << "</DataArray>\n"
    << "</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  write_file_atomic(path, o.str());
}

void PvdCollection::add(double time_s, const std::string& file) {
  entries_.emplace_back(time_s, file);
  write();
}

void PvdCollection::write() const {
  std::ostringstream o;
  o.precision(12);
  o << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
       "<Collection>\n";
  for (const auto& [t, f] : entries_)
    o << "<DataSet timestep=\"" << t << "\" group=\"\" part=\"0\" file=\"" << f << "\"/>\n";
  o << "</Collection>\n</VTKFile>\n";
  write_file_atomic(path_, o.str());
}

}  // namespace biodem::output
