// Shared part of cgns_fuzz.cpp and exodus_fuzz.cpp: their readers take a
// file name (libcgns and the Exodus II library read files, not bytes), so
// the input's bytes are written to a file of this process first, read with
// the same reader read_mesh uses (it validates the file the same way:
// cg_is_cgns / ex_open, then every count against the file's size), and the
// accepted mesh goes through the usual topology checks and a write /
// re-read round trip.
#pragma once
#include <unistd.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "fuzz_common.hpp"

namespace tetopt_fuzz {

/// A file name of this process for the input (`what` 0) or the round trip (1).
inline std::string lib_file(const char* ext, int what) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir && *dir ? dir : "/tmp") + "/tetopt-fuzz-" + std::to_string(::getpid()) + "-" +
         std::to_string(what) + ext;
}

inline void write_bytes(const std::string& path, const uint8_t* data, size_t size) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) die("cannot write", path);
  if (size && std::fwrite(data, 1, size, f) != size) die("cannot write", path);
  std::fclose(f);
}

/// m's tets (and their refs) grouped by ref in order of first appearance,
/// each group in mesh order: what the CGNS and Exodus writers write.
inline void group_by_ref(tetopt::TetMesh& m) {
  std::map<int32_t, size_t> at;
  std::vector<std::vector<int32_t>> groups;
  for (int32_t t = 0; t < m.nt(); ++t) {
    auto it = at.find(m.tet_ref[t]);
    if (it == at.end()) {
      it = at.emplace(m.tet_ref[t], groups.size()).first;
      groups.emplace_back();
    }
    groups[it->second].push_back(t);
  }
  std::vector<int32_t> tets, refs;
  for (const auto& g : groups)
    for (int32_t t : g) {
      tets.insert(tets.end(), m.tets.begin() + 4 * t, m.tets.begin() + 4 * t + 4);
      refs.push_back(m.tet_ref[t]);
    }
  m.tets = std::move(tets);
  m.tet_ref = std::move(refs);
}

}  // namespace tetopt_fuzz
