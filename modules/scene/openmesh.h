// Internal to weft.scene: the OpenMesh types it uses and a guard that captures what OpenMesh
// prints to omerr/omlog (so its complaints become weft warnings instead of stray stderr).
// Included in the global module fragment of the units that use OpenMesh.
#pragma once

#include <iostream>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

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

// OpenMesh's streams are process-wide; one capture at a time.
inline std::mutex& stream_mutex() {
  static std::mutex m;
  return m;
}

// While alive, omerr/omlog/omout go to a string instead of the terminal.
class StreamCapture {
 public:
  StreamCapture() : lock_(stream_mutex()) {
    ::omerr().flush();
    ::omlog().flush();
    ::omout().flush();
    had_cerr_ = ::omerr().disconnect(std::cerr);
    had_clog_ = ::omlog().disconnect(std::clog);
    had_cout_ = ::omout().disconnect(std::cout);
    ::omerr().connect(text_);
    ::omlog().connect(text_);
    ::omout().connect(text_);
  }
  ~StreamCapture() {
    ::omerr().flush();
    ::omlog().flush();
    ::omout().flush();
    ::omerr().disconnect(text_);
    ::omlog().disconnect(text_);
    ::omout().disconnect(text_);
    if (had_cerr_) ::omerr().connect(std::cerr);
    if (had_clog_) ::omlog().connect(std::clog);
    if (had_cout_) ::omout().connect(std::cout);
  }
  StreamCapture(const StreamCapture&) = delete;
  StreamCapture& operator=(const StreamCapture&) = delete;

  // The captured text, one entry per non-empty line.
  std::vector<std::string> lines() {
    ::omerr().flush();
    ::omlog().flush();
    ::omout().flush();
    std::vector<std::string> out;
    std::istringstream in(text_.str());
    for (std::string line; std::getline(in, line);) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      std::size_t start = line.find_first_not_of(' ');
      if (start != std::string::npos) out.push_back(line.substr(start));
    }
    return out;
  }

 private:
  std::lock_guard<std::mutex> lock_;
  std::ostringstream text_;
  bool had_cerr_ = false;
  bool had_clog_ = false;
  bool had_cout_ = false;
};

}  // namespace weft::scene::om
