// check_paths (cli.hpp): the files a command reads and writes are distinct
// and every output can be written, before any work; shown, the one way a
// file name or a message gets into a line.  Shared by tetopt and tetopt-mpi.
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>

#include "../../src/io/common.hpp"  // escaped_name (the CLI has no src/ on its include path)
#include "cli.hpp"
#include "tetopt/io.hpp"

namespace tetopt_cli {

using namespace tetopt;

std::string shown(const std::string& s) { return detail::escaped_name(s); }

bool field_is_vtu(const char* cmd, const std::string& field) {
  if (field.empty() || format_from_path(field) == Format::Vtu) return true;
  std::fprintf(stderr, "%s: --field writes VTK XML (.vtu): its name must end in .vtu, not '%s'\n", cmd,
               shown(field).c_str());
  return false;
}

namespace {
// The folder of a path ("." when it names none).
std::string folder_of(const std::string& p) {
  const size_t slash = p.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : p.substr(0, slash);
}
// The same file: the same inode when both exist, else the same canonical
// folder and name of what a write to each would replace (a dangling link to
// the other output, "ln -s ../o.mesh sub/x.vtu", let --field overwrite the
// improved mesh).
bool same_file(const std::string& a_path, const std::string& b_path) {
  const std::string a = output_target(a_path), b = output_target(b_path);
  struct stat sa {}, sb {};
  const bool ea = ::stat(a.c_str(), &sa) == 0, eb = ::stat(b.c_str(), &sb) == 0;
  if (ea && eb) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  if (ea != eb) return false;
  char* ra = ::realpath(folder_of(a).c_str(), nullptr);
  char* rb = ::realpath(folder_of(b).c_str(), nullptr);
  const bool same = ra && rb && std::string(ra) == rb &&
                    a.substr(a.find_last_of('/') + 1) == b.substr(b.find_last_of('/') + 1);
  std::free(ra);
  std::free(rb);
  return same;
}
}  // namespace

namespace {
// The files a path reads or writes: mesh_files for a mesh; reports and field
// files are one file whatever their extension (mesh = false).
std::vector<std::string> files_of(const std::string& p, bool mesh) { return mesh ? mesh_files(p) : std::vector<std::string>{p}; }
}  // namespace

int check_paths(const char* cmd, const std::vector<std::pair<std::string, std::string>>& files, bool out_is_mesh,
                bool out_may_be_in) {
  for (size_t i = 0; i < files.size(); ++i) {
    if (files[i].second.empty()) continue;
    for (size_t j = i + 1; j < files.size(); ++j) {
      if (files[j].second.empty() || (out_may_be_in && i == 0 && j == 1)) continue;
      // files[0] is IN; with out_is_mesh files[1] is the output mesh.
      for (const std::string& a : files_of(files[i].second, i == 0 || (out_is_mesh && i == 1)))
        for (const std::string& b : files_of(files[j].second, out_is_mesh && j == 1))
          if (same_file(a, b)) {
            // Over the input, the rule is the same for every output, -o included.
            const char* rule = i == 0 ? "; no output may replace IN: write elsewhere, then rename" : "";
            if (a == files[i].second && b == files[j].second)
              std::fprintf(stderr, "%s: %s and %s name the same file '%s'%s\n", cmd, files[i].first.c_str(),
                           files[j].first.c_str(), shown(b).c_str(), rule);
            else
              std::fprintf(stderr, "%s: %s ('%s') and %s ('%s') both name the file '%s' (a TetGen name stands for its .node, .ele and .face)%s\n",
                           cmd, files[i].first.c_str(), shown(files[i].second).c_str(), files[j].first.c_str(),
                           shown(files[j].second).c_str(), shown(b).c_str(), rule);
            return kExitUsage;
          }
    }
  }
  // Every output can be written (its folder exists and is writable, and it
  // is no folder, device or FIFO), so that no run does its work and then
  // fails on its last output with the first ones written.
  for (size_t i = 1; i < files.size(); ++i) {
    if (files[i].second.empty()) continue;
    if (const Status s = check_output_path(files[i].second); !s) {
      std::fprintf(stderr, "%s: %s (for %s)\n", cmd, shown(s.message).c_str(), files[i].first.c_str());
      return kExitOutput;
    }
  }
  return kExitOk;
}

}  // namespace tetopt_cli
