// Internal to weft.scene: the OpenMesh types it uses and a guard that keeps OpenMesh quiet
// (its complaints become weft's own counted warnings and errors instead of stray stderr).
// Included in the global module fragment of the units that use OpenMesh.
#pragma once

#include <mutex>

#pragma clang diagnostic push
#pragma clang diagnostic ignored "-Weverything"
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/ImporterT.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#pragma clang diagnostic pop

namespace weft::scene::om {

using PolyMesh = OpenMesh::PolyMesh_ArrayKernelT<>;
using TriMesh = OpenMesh::TriMesh_ArrayKernelT<>;

// OpenMesh's streams are process-wide; one guard at a time (never nested).
inline std::mutex& stream_mutex() {
  static std::mutex m;
  return m;
}

// While alive, OpenMesh's omerr/omlog/omout print nothing: weft counts what OpenMesh would
// complain about (refused faces, bad indices) and reports it as warnings and errors.
// (Disabling rather than redirecting: OpenMesh's mostream::disconnect leaks its target.)
class QuietStreams {
 public:
  QuietStreams() : lock_(stream_mutex()) {
    for (int i = 0; i < 3; ++i) {
      OpenMesh::mostream& s = stream(i);
      s.flush();
      was_enabled_[i] = s.is_enabled();
      s.disable();
    }
  }
  ~QuietStreams() {
    for (int i = 0; i < 3; ++i) {
      OpenMesh::mostream& s = stream(i);
      s.flush();  // drops what was buffered while disabled
      if (was_enabled_[i]) s.enable();
    }
  }
  QuietStreams(const QuietStreams&) = delete;
  QuietStreams& operator=(const QuietStreams&) = delete;

 private:
  static OpenMesh::mostream& stream(int i) { return i == 0 ? ::omerr() : i == 1 ? ::omlog() : ::omout(); }
  std::lock_guard<std::mutex> lock_;
  bool was_enabled_[3] = {true, true, true};
};

}  // namespace weft::scene::om
