#!/usr/bin/env bash
# Sourced by bench/solver.sh, tests/scripts/test_simplefoam.sh and
# test_fem_accuracy.sh: meshes of tests/data/gmsh/flow_box.geo and an
# OpenFOAM case for them, solved by Debian's OpenFOAM (v1912).
#
#   flow_box_raw S OUT TETOPT   raw `tetgen -pQ` output of the geometry at
#                               size factor S (gmsh's surface, the body a
#                               hole: mesh_to_smesh.py) as OUT (.mesh);
#                               scratch files beside it
#   foam_case MESH DIR TETOPT   writes DIR (system/, constant/, 0/) with
#                               MESH as constant/polyMesh (tetopt convert)
#   foam_run DIR                checkMesh, then simpleFoam, in DIR
#   foam_summary DIR            one line: key=value for what they said
#   foam_laplace MESH DIR TETOPT  the Laplacian's error on MESH
#                               (bench/foam_laplace.py), its one line
#
# The flow: laminar, steady, nu = 0.01, 1 m/s at the inlet (patch1), p = 0
# at the outlet (patch2), slip on the box's sides (patch3), no slip on the
# body (patch4); Reynolds number 120 on the body's length (1.2).  SIMPLE with
# the settings of OpenFOAM's own steady tutorials (p 0.3, U 0.7, GAMG for p,
# linearUpwind for U) and one non-orthogonal corrector, as tetrahedral meshes
# are usually run; it stops at initial residuals p 1e-4, U 1e-5 or after
# 1,500 iterations.  The drag coefficient and its pressure and viscous parts
# come from the forces function object's x forces over 0.5 rho U^2 A, with
# A = 0.197 (the ellipsoid's frontal area pi 0.24^2 plus the fin's 0.04 x
# 0.4; what forceCoeffs would divide by).
FOAM_BENCH=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
foam() { ( set +u; export WM_PROJECT_DIR=/usr/share/openfoam; . /usr/share/openfoam/etc/bashrc > /dev/null 2>&1; "$@" ) ; }

foam_case() {
  local mesh=$1 dir=$2 tetopt=$3
  rm -rf "$dir"
  mkdir -p "$dir/system" "$dir/constant" "$dir/0"
  "$tetopt" convert "$mesh" "$dir/constant/polyMesh" 2> "$dir/convert.log" || return 1
  local h='FoamFile { version 2.0; format ascii; class dictionary; object'
  cat > "$dir/system/controlDict" <<EOF
$h controlDict; }
application simpleFoam; startFrom startTime; startTime 0; stopAt endTime; endTime 1500; deltaT 1;
writeControl timeStep; writeInterval 100000; writeFormat binary; writePrecision 10; runTimeModifiable false;
functions
{
    forces { type forces; libs ("libforces.so"); writeControl timeStep; writeInterval 1; log false;
      patches (patch4); rho rhoInf; rhoInf 1; CofR (0 0 0); }
}
EOF
  cat > "$dir/system/fvSchemes" <<EOF
$h fvSchemes; }
ddtSchemes { default steadyState; }
gradSchemes { default Gauss linear; }
divSchemes { default none; div(phi,U) bounded Gauss linearUpwind grad(U); div((nuEff*dev2(T(grad(U))))) Gauss linear; }
laplacianSchemes { default Gauss linear corrected; }
interpolationSchemes { default linear; }
snGradSchemes { default corrected; }
EOF
  cat > "$dir/system/fvSolution" <<EOF
$h fvSolution; }
solvers
{
    p { solver GAMG; smoother GaussSeidel; tolerance 1e-7; relTol 0.05; maxIter 200; }
    U { solver smoothSolver; smoother symGaussSeidel; tolerance 1e-8; relTol 0.1; maxIter 200; }
}
SIMPLE { nNonOrthogonalCorrectors 1; consistent no; residualControl { p 1e-4; U 1e-5; } }
relaxationFactors { fields { p 0.3; } equations { U 0.7; } }
EOF
  echo "$h transportProperties; } transportModel Newtonian; nu 0.01;" > "$dir/constant/transportProperties"
  echo "$h turbulenceProperties; } simulationType laminar;" > "$dir/constant/turbulenceProperties"
  cat > "$dir/0/U" <<'EOF'
FoamFile { version 2.0; format ascii; class volVectorField; object U; }
dimensions [0 1 -1 0 0 0 0]; internalField uniform (1 0 0);
boundaryField
{
    patch1 { type fixedValue; value uniform (1 0 0); }
    patch2 { type inletOutlet; inletValue uniform (0 0 0); value uniform (1 0 0); }
    patch3 { type slip; }
    patch4 { type noSlip; }
}
EOF
  cat > "$dir/0/p" <<'EOF'
FoamFile { version 2.0; format ascii; class volScalarField; object p; }
dimensions [0 2 -2 0 0 0 0]; internalField uniform 0;
boundaryField
{
    patch1 { type zeroGradient; }
    patch2 { type fixedValue; value uniform 0; }
    patch3 { type zeroGradient; }
    patch4 { type zeroGradient; }
}
EOF
}

foam_run() {
  local dir=$1
  ( cd "$dir" && foam checkMesh > check.log 2>&1
    local t0 t1
    t0=$(date +%s.%N)
    foam simpleFoam > solve.log 2>&1
    echo $? > solve.rc
    t1=$(date +%s.%N)
    awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f\n", b - a }' > solve.seconds )
}

# cells, checkMesh's largest non-orthogonality and skewness, its faces above
# 70 degrees, "Mesh OK." (ok=1), simpleFoam's iterations to its residual
# control (converged=N) or the last iteration it reached (diverged=N, with
# its exit status), the drag coefficient with its pressure and viscous
# parts at the last iteration, the solve's wall seconds.
foam_summary() {
  local dir=$1
  local cells nonorth severe skew ok conv last rc secs state
  cells=$(awk '/^ *cells:/ { print $2; exit }' "$dir/check.log")
  nonorth=$(awk '/Mesh non-orthogonality Max/ { print $4; exit }' "$dir/check.log")
  severe=$(grep -o 'severely non-orthogonal (> 70 degrees) faces: [0-9]*' "$dir/check.log" | awk '{ print $NF }')
  skew=$(awk '/Max skewness/ { print $4; exit }' "$dir/check.log")
  ok=$(grep -c '^Mesh OK\.' "$dir/check.log")
  conv=$(grep -o 'SIMPLE solution converged in [0-9]* iterations' "$dir/solve.log" | awk '{ print $5 }')
  last=$(awk '/^Time = / { t = $3 } END { print t + 0 }' "$dir/solve.log")
  rc=$(cat "$dir/solve.rc" 2> /dev/null || echo 1)
  secs=$(cat "$dir/solve.seconds" 2> /dev/null)
  # The drag and its pressure and viscous parts: x of forces.dat's three
  # vectors (total, pressure, viscous) over 0.5 rho U^2 A.
  local parts
  parts=$(awk '!/^#/ { l = $0 } END { gsub(/[()]/, " ", l); split(l, f, " "); q = 0.5 * 0.197
                 printf "Cd=%.10g Cd_pressure=%.4f Cd_viscous=%.4f", f[2] / q, f[5] / q, f[8] / q }' \
            "$dir"/postProcessing/forces/0/force.dat 2> /dev/null)
  if [ -n "$conv" ] && [ "$rc" = 0 ]; then state="converged=$conv"; else state="diverged=$last rc=$rc"; fi
  echo "cells=${cells:-?} nonorth_max=${nonorth:-?} severe_nonorth=${severe:-0} skewness_max=${skew:-?} mesh_ok=$ok $state ${parts:-Cd=? Cd_pressure=? Cd_viscous=?} solve_s=${secs:-?}"
}

flow_box_raw() {
  local s=$1 out=$2 tetopt=$3 b=${2%.mesh}
  gmsh -2 -nt 1 -setnumber s "$s" -format mesh "$FOAM_BENCH/../tests/data/gmsh/flow_box.geo" -o "${b}_surf.mesh" \
    > "${b}_gmsh.log" 2>&1 &&
    /usr/bin/python3 "$FOAM_BENCH/../tests/scripts/mesh_to_smesh.py" "${b}_surf.mesh" "${b}_surf.smesh" 0,0,0 &&
    tetgen -pQ "${b}_surf.smesh" > "${b}_tetgen.log" 2>&1 &&
    "$tetopt" convert "${b}_surf.1.node" "$out" 2> /dev/null
}

foam_laplace() {
  foam_case "$1" "$2" "$3" && /usr/bin/python3 "$FOAM_BENCH/foam_laplace.py" write "$2" &&
    (cd "$2" && foam laplacianFoam > laplace.log 2>&1) && /usr/bin/python3 "$FOAM_BENCH/foam_laplace.py" error "$2"
}
