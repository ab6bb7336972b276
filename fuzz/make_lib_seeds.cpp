// Writes the seeds of cgns_fuzz and exodus_fuzz (fuzz/corpus/cgns/seed-*,
// fuzz/corpus/exodus/seed-*): their formats are HDF5 / ADF and netCDF
// files, which fuzz/make_seeds.py cannot write without the libraries, so
// tetopt's own writers write them here, from small meshes (kept small:
// fuzz/run.sh passes -max_len).
//   usage: make_lib_seeds CORPUS_DIR     (fuzz/run.sh and check_seeds.sh run the targets on them)
#include <cstdio>
#include <string>

#include "io/common.hpp"
#include "tetopt/generate.hpp"
#include "tetopt/io.hpp"

using namespace tetopt;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_lib_seeds CORPUS_DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  // One cube (6 tets) with its 12 boundary triangles; a 2x1x1 box in two
  // regions with named groups, refs that need the files' ref notes, vertex refs.
  TetMesh one = make_box_mesh({.nx = 1, .ny = 1, .nz = 1});
  TetMesh two = make_box_mesh({.nx = 2, .ny = 1, .nz = 1, .jitter = 0.2, .seed = 4, .regions = 2});
  for (int32_t i = 0; i < two.ntri(); ++i) two.tri_ref[i] = i % 2 ? 0 : 9;
  two.vert_ref.assign(two.nv(), 0);
  two.vert_ref[1] = 4;
  two.physical_names = {{3, 2, "solid"}, {2, 9, "wall"}, {0, 4, "probe"}};
  TetMesh bare = one;
  bare.tris.clear();
  bare.tri_ref.clear();
  int bad = 0;
  auto check = [&](const Status& s, const std::string& what) {
    if (!s) {
      std::fprintf(stderr, "make_lib_seeds: %s: %s\n", what.c_str(), s.message.c_str());
      ++bad;
    }
  };
  if (cgns_available()) {
    // HDF5 only: the reader refuses ADF files (src/io/cgns.cpp: libcgns
    // 3.4 overruns a heap buffer on some malformed ADF files).
    check(detail::write_cgns_typed(one, dir + "/cgns/seed-hdf5-cube", 2), "cgns hdf5 cube");
    check(detail::write_cgns_typed(two, dir + "/cgns/seed-hdf5-two-regions-named", 2), "cgns hdf5 two");
    check(detail::write_cgns_typed(bare, dir + "/cgns/seed-hdf5-no-triangles", 2), "cgns hdf5 bare");
  }
  if (exodus_available()) {
    check(format_exodus_file(one, dir + "/exodus/seed-cube"), "exodus cube");
    check(format_exodus_file(two, dir + "/exodus/seed-two-regions-named"), "exodus two");
    check(format_exodus_file(bare, dir + "/exodus/seed-no-sidesets"), "exodus bare");
  }
  return bad ? 1 : 0;
}
