#include "io/part_writer.h"

#include <stdexcept>

#include "base/distribution.h"
#include "io/formats.h"
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"

namespace qjulia::detail {
namespace {

// Writes `bytes` at `offset` in blocks; false on failure.
class RangeWriter {
 public:
  RangeWriter(Comm& comm, std::uint64_t offset) : comm_(comm), offset_(offset) {}
  char* reserve(std::size_t n) {
    if (buffer_.size() + n > kBlock) flush();
    buffer_.resize(buffer_.size() + n);
    return buffer_.data() + buffer_.size() - n;
  }
  void flush() {
    if (!buffer_.empty() && ok) ok = comm_.file_write_at(offset_, buffer_.data(), buffer_.size());
    offset_ += buffer_.size();
    buffer_.clear();
  }
  bool ok = true;

 private:
  static constexpr std::size_t kBlock = std::size_t{8} << 20;
  Comm& comm_;
  std::uint64_t offset_;
  std::string buffer_;
};

}  // namespace

void write_mesh_part(const std::string& path, const TriMesh& mesh, const MeshPart& part,
                     const ExportOptions& opts) {
  Comm& comm = *part.comm;
  const MeshFormat format = format_from_path(path);
  if (!part_writable(format))
    throw std::logic_error("write_mesh_part: " + path + " is neither PLY nor STL");
  if (mesh.normals.size() != mesh.positions.size())
    throw std::logic_error("write_mesh_part: the part has no normals");
  // Rank 0 makes the temporary file (the checks and the naming of every output file).
  std::unique_ptr<AtomicFile> file;
  std::string temp;
  on_rank_zero(comm, [&] {
    file = std::make_unique<AtomicFile>(path, opts.cancel);
    file->close_for_external();
    temp = file->temp_path();
  });
  comm.broadcast(temp);
  // The same ExportData on every rank (the parameters, the normals made unit length) for the
  // records of its own vertices.
  const ExportData data = export_data(path, mesh, opts);
  auto fail_unless = [&](bool ok, const std::string& what) {
    agree_on(comm, ok ? nullptr
                      : std::make_exception_ptr(std::runtime_error(
                            path + ": " + what + " on rank " + std::to_string(comm.rank()))));
  };
  fail_unless(comm.file_open(temp), "cannot open the file");
  bool ok = true;
  if (format == MeshFormat::kPly) {
    const std::string header = ply_header(data, part.vertices_total, part.faces_total);
    if (comm.rank() == 0) ok = comm.file_write_at(0, header.data(), header.size());
    const std::size_t record = ply_vertex_record(data);
    const std::uint64_t faces_at = header.size() + part.vertices_total * record;
    RangeWriter edges(comm, header.size() + part.edge_first * record);
    for (std::size_t v = 0; v < part.edges; ++v) put_ply_vertex(edges.reserve(record), data, v);
    edges.flush();
    RangeWriter centres(comm, header.size() + part.centre_first * record);
    for (std::size_t v = part.edges; v < part.edges + part.centres; ++v)
      put_ply_vertex(centres.reserve(record), data, v);
    centres.flush();
    RangeWriter faces(comm, faces_at + part.face_first * kPlyFaceRecord);
    for (const auto& t : mesh.triangles) put_ply_face(faces.reserve(kPlyFaceRecord), t);
    faces.flush();
    ok = ok && edges.ok && centres.ok && faces.ok;
  } else {
    const std::string header = stl_header(data, static_cast<std::uint32_t>(part.faces_total));
    if (comm.rank() == 0) ok = comm.file_write_at(0, header.data(), header.size());
    RangeWriter faces(comm, header.size() + part.face_first * kStlFaceRecord);
    for (const auto& t : mesh.triangles)
      put_stl_face(faces.reserve(kStlFaceRecord), part.position(mesh, t[0]),
                   part.position(mesh, t[1]), part.position(mesh, t[2]));
    faces.flush();
    ok = ok && faces.ok;
  }
  if (!comm.file_close()) ok = false;
  fail_unless(ok, "write failed");
  on_rank_zero(comm, [&] { file->commit(); });  // flushed to the disk, renamed
}

}  // namespace qjulia::detail
