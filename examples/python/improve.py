"""Improve a mesh with the tetopt package (pip install .), following the run.

usage: python3 improve.py IN OUT      (any format tetopt reads and writes)
"""
import sys

import tetopt

src, dst = sys.argv[1], sys.argv[2]
mesh = tetopt.read(src)


def progress(phase, round_, fraction, worst):
    print(f"round {round_} {phase:13s} {fraction:4.0%}  worst alpha {worst:.4f}")
    return True  # False stops the run here; the mesh comes back valid (report["stopped_early"])


improved, report = tetopt.improve_mesh(mesh, progress=progress)
tetopt.write(dst, improved)
print(f"worst alpha {report['before']['alpha_worst']:.4f} -> {report['after']['alpha_worst']:.4f},",
      "boundary unchanged:", "yes" if report["boundary_unchanged"]["ok"] else "NO")
sys.exit(0 if report["boundary_unchanged"]["ok"] else 3)
