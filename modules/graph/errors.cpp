// GraphErrors: every problem compile() found, formatted for people and convertible to the
// weft::Error the rest of the engine passes around.
module;
#include <cstddef>
#include <string>
#include <string_view>
module weft.graph;
import weft.core;

namespace weft {

std::string_view to_string(GraphErrorKind kind) {
  switch (kind) {
    case GraphErrorKind::Cycle: return "cycle";
    case GraphErrorKind::UnwrittenRead: return "unwritten read";
    case GraphErrorKind::MultipleWriters: return "multiple writers";
    case GraphErrorKind::UnsupportedUsage: return "unsupported usage";
    case GraphErrorKind::MissingUsage: return "missing usage";
    case GraphErrorKind::MismatchedAttachmentSizes: return "mismatched attachment sizes";
    case GraphErrorKind::OutputNeverWritten: return "output never written";
    case GraphErrorKind::UndeclaredAccess: return "undeclared access";
    case GraphErrorKind::InvalidHandle: return "invalid handle";
    case GraphErrorKind::ConflictingUsage: return "conflicting usage";
    case GraphErrorKind::InvalidDescriptor: return "invalid descriptor";
    case GraphErrorKind::WrongPassKind: return "wrong pass kind";
    case GraphErrorKind::SampleCount: return "sample count";
    case GraphErrorKind::Memory: return "memory";
    case GraphErrorKind::DuplicateName: return "duplicate name";
  }
  return "?";
}

std::size_t GraphErrors::count(GraphErrorKind kind) const {
  std::size_t n = 0;
  for (const GraphError& e : errors) n += e.kind == kind ? 1 : 0;
  return n;
}

const GraphError* GraphErrors::find(GraphErrorKind kind) const {
  for (const GraphError& e : errors)
    if (e.kind == kind) return &e;
  return nullptr;
}

std::string GraphErrors::to_string() const {
  std::string out = weft::format("render graph '{}': {} error{}", graph_name, errors.size(), errors.size() == 1 ? "" : "s");
  for (const GraphError& e : errors) {
    out += "\n  - ";
    out += e.message;
  }
  return out;
}

}  // namespace weft
