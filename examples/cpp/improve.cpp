// Improve a mesh file with the installed tetopt library, following the run.
//   cmake -S examples/cpp -B build-example -DCMAKE_PREFIX_PATH=<prefix>
//   cmake --build build-example && build-example/improve_example in.mesh out.mesh
#include <cstdio>

#include "tetopt/improve.hpp"
#include "tetopt/io.hpp"
#include "tetopt/mesh.hpp"

int main(int argc, char** argv) {
  if (argc != 3) { std::fprintf(stderr, "usage: %s IN OUT\n", argv[0]); return 1; }
  tetopt::TetMesh m;
  tetopt::Status s = tetopt::read_mesh(argv[1], m);
  if (s) s = tetopt::build_topology(m);  // adjacency and constrained entities
  if (!s) { std::fprintf(stderr, "%s\n", s.message.c_str()); return 2; }
  tetopt::ImproveOptions opt;
  opt.progress = [](const tetopt::ImproveProgress& p) {
    std::printf("round %d %-13s %3.0f%%  worst alpha %.4f\n", p.round, p.phase, 100 * p.fraction, p.worst);
    return true;  // false would stop here with a valid mesh (ErrorCode::Stopped)
  };
  tetopt::ImproveReport rep;
  s = tetopt::improve(m, opt, rep);
  if (!s.mesh_valid()) { std::fprintf(stderr, "improve: %s\n", s.message.c_str()); return 3; }
  std::printf("worst alpha %.4f -> %.4f, boundary unchanged: %s\n", rep.before.alpha_worst, rep.after.alpha_worst,
              rep.invariants_ok ? "yes" : "NO");
  if (s = tetopt::write_mesh(argv[2], m); !s) { std::fprintf(stderr, "%s\n", s.message.c_str()); return 4; }
  return rep.invariants_ok ? 0 : 3;
}
