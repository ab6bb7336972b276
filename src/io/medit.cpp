// Medit .mesh / .meshb — placeholder until the reader lands (returns Unsupported).
#include "tetopt/io.hpp"
namespace tetopt {
Status parse_medit(std::string_view, const std::string& n, TetMesh&) { return Status::error(ErrorCode::Unsupported, n + ": Medit reader not built yet"); }
Status parse_meditb(std::string_view, const std::string& n, TetMesh&) { return Status::error(ErrorCode::Unsupported, n + ": Medit reader not built yet"); }
Status format_medit(const TetMesh&, std::string&) { return Status::error(ErrorCode::Unsupported, "Medit writer not built yet"); }
Status format_meditb(const TetMesh&, std::string&, int) { return Status::error(ErrorCode::Unsupported, "Medit writer not built yet"); }
}  // namespace tetopt
