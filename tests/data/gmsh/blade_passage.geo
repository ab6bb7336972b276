// One blade passage of a turbine or compressor row: a cambered, twisted
// blade with a sharp trailing edge, from hub (z = 0) to shroud (z = span),
// in a box one pitch wide.  The fluid region only (the blade is a hole).
// Issue 27 item 2 met a blade whose worst tet had two boundary faces
// meeting at its sharp trailing edge; tests/scripts/test_blade.sh and
// bench/remesh.sh use this one to check insertion mode on such a blade.
//   gmsh -3 -setnumber s 0.06 blade_passage.geo                (a mesher's output)
//   gmsh -2 -format stl ... && tetgen -pQ FILE.stl             (raw tetgen output;
//   TetGen's .mesh reader stops on gmsh's .mesh surface of it)
// Airfoil: NACA 4-digit camber line and thickness (Abbott & von Doenhoff,
// Theory of Wing Sections, 1959, §6.4), with the closed-trailing-edge
// coefficient -0.1036, so upper and lower sides meet at a point.
SetFactory("OpenCASCADE");
DefineConstant[ s = 0.08 ];      // largest element size
DefineConstant[ tk = 0.12 ];     // thickness / chord
DefineConstant[ cam = 0.05 ];    // camber / chord
DefineConstant[ pc = 0.4 ];      // chordwise position of the largest camber
DefineConstant[ hub_stagger = 25 ];    // degrees
DefineConstant[ tip_stagger = 45 ];
DefineConstant[ span = 0.8 ];
DefineConstant[ pitch = 1.0 ];
n = 30;  // points per side

// Section at height zc, stagger angle st (degrees): curves of the upper and
// lower sides, returned as a wire in wires[].
Macro Section
  st_r = st * Pi / 180;
  up[] = {};
  lo[] = {};
  For i In {0:n}
    // cosine spacing, dense at both edges
    xx = 0.5 * (1 - Cos(Pi * i / n));
    yt = 5 * tk * (0.2969 * Sqrt(xx) - 0.1260 * xx - 0.3516 * xx^2 + 0.2843 * xx^3 - 0.1036 * xx^4);
    If (xx < pc)
      yc = cam / pc^2 * (2 * pc * xx - xx^2);
      dy = 2 * cam / pc^2 * (pc - xx);
    Else
      yc = cam / (1 - pc)^2 * ((1 - 2 * pc) + 2 * pc * xx - xx^2);
      dy = 2 * cam / (1 - pc)^2 * (pc - xx);
    EndIf
    th = Atan(dy);
    xu = xx - yt * Sin(th) - 0.5; yu = yc + yt * Cos(th);
    xl = xx + yt * Sin(th) - 0.5; yl = yc - yt * Cos(th);
    // stagger: rotate about the mid-chord
    If (i == 0)
      le = newp; Point(le) = {xu * Cos(st_r) - yu * Sin(st_r), xu * Sin(st_r) + yu * Cos(st_r), zc};
      up[] += le; lo[] += le;
    ElseIf (i == n)
      te = newp; Point(te) = {xu * Cos(st_r) - yu * Sin(st_r), xu * Sin(st_r) + yu * Cos(st_r), zc};
      up[] += te; lo[] += te;
    Else
      pu = newp; Point(pu) = {xu * Cos(st_r) - yu * Sin(st_r), xu * Sin(st_r) + yu * Cos(st_r), zc};
      up[] += pu;
      pl = newp; Point(pl) = {xl * Cos(st_r) - yl * Sin(st_r), xl * Sin(st_r) + yl * Cos(st_r), zc};
      lo[] += pl;
    EndIf
  EndFor
  cu = newc; Spline(cu) = up[];
  cl = newc; Spline(cl) = lo[];
  w = newll; Wire(w) = {cu, cl};
  wires[] += w;
Return

wires[] = {};
zc = 0; st = hub_stagger; Call Section;
zc = span; st = tip_stagger; Call Section;
ThruSections(10) = {wires[0], wires[1]};
Box(11) = {-1.2, -0.5 * pitch, 0, 2.4, pitch, span};
BooleanDifference(12) = { Volume{11}; Delete; }{ Volume{10}; Delete; };
Mesh.MeshSizeMax = s;
Mesh.MeshSizeMin = s / 6;
Mesh.MeshSizeFromCurvature = 24;
