// TetGen — placeholder until the reader lands (returns Unsupported).
#include "tetopt/io.hpp"
namespace tetopt {
Status parse_tetgen(std::string_view, std::string_view, std::string_view, const std::string& n, TetMesh&) { return Status::error(ErrorCode::Unsupported, n + ": TetGen reader not built yet"); }
Status format_tetgen(const TetMesh&, std::string&, std::string&, std::string&) { return Status::error(ErrorCode::Unsupported, "TetGen writer not built yet"); }
}  // namespace tetopt
