// VTK — placeholder until the reader lands (returns Unsupported).
#include "tetopt/io.hpp"
namespace tetopt {
Status parse_vtk(std::string_view, const std::string& n, TetMesh&) { return Status::error(ErrorCode::Unsupported, n + ": VTK reader not built yet"); }
Status parse_vtu(std::string_view, const std::string& n, TetMesh&) { return Status::error(ErrorCode::Unsupported, n + ": VTK reader not built yet"); }
Status format_vtk(const TetMesh&, std::string&, bool) { return Status::error(ErrorCode::Unsupported, "VTK writer not built yet"); }
Status format_vtu(const TetMesh&, std::string&) { return Status::error(ErrorCode::Unsupported, "VTK writer not built yet"); }
}  // namespace tetopt
