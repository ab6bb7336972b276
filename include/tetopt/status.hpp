// tetopt/status.hpp — how the library reports failure.
//
// The library never prints and never exits.  Functions that can fail on
// user input return a Status: a code, a one-line message that names the file
// and the line or record ("mesh.mesh:12: vertex index 99 out of range 1..8"),
// and the line number when one applies.  Logging goes through LogFn callbacks.
#pragma once
#include <functional>
#include <string>
#include <utility>

namespace tetopt {

enum class ErrorCode {
  Ok = 0,
  Io,           ///< the file could not be opened, read or written
  Parse,        ///< the file is malformed (truncated, bad number, lying count, ...)
  InvalidMesh,  ///< the file parsed but the mesh breaks an invariant (index range, NaN, non-manifold)
  Unsupported,  ///< format, version or feature tetopt does not handle
  Invariant,    ///< an internal invariant failed (a bug): nothing is written
  OutOfMemory,  ///< the input (or the output being built) needs more memory than there is
  /// Not a failure, not a success: improve() stopped early at the caller's
  /// request (ImproveOptions::progress returned false, or `interrupted` was
  /// set).  The mesh is valid (every committed operation keeps the
  /// invariants) and may be used; ImproveReport::stopped_early says so too.
  Stopped,
};

struct Status {
  ErrorCode code = ErrorCode::Ok;
  std::string message;  ///< empty when ok
  long line = 0;        ///< 1-based line or record number, 0 when not applicable

  bool ok() const { return code == ErrorCode::Ok; }
  /// Stopped early at the caller's request, mesh valid (ok() is false).
  bool stopped() const { return code == ErrorCode::Stopped; }
  /// The mesh may be used: success, or stopped early.
  bool mesh_valid() const { return ok() || stopped(); }
  explicit operator bool() const { return ok(); }

  static Status success() { return {}; }
  static Status error(ErrorCode c, std::string msg, long line = 0) {
    return Status{c, std::move(msg), line};
  }
};

/// Severity of a log message sent to a LogFn.
enum class LogLevel { Debug, Info, Progress, Warning };
using LogFn = std::function<void(LogLevel, const std::string&)>;

}  // namespace tetopt
