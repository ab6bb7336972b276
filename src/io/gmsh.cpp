// Gmsh — placeholder until the reader lands (returns Unsupported).
#include "tetopt/io.hpp"
namespace tetopt {
Status parse_gmsh(std::string_view, const std::string& n, TetMesh&) { return Status::error(ErrorCode::Unsupported, n + ": Gmsh reader not built yet"); }
Status format_gmsh(const TetMesh&, std::string&, int, bool) { return Status::error(ErrorCode::Unsupported, "Gmsh writer not built yet"); }
}  // namespace tetopt
