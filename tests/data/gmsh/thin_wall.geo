// Walls one tet thick inside a box of fluid (issue 27, item 3): a curved
// shell (a cylinder 0.6 in radius, t thick) and two tilted plates, each t
// thick, meshed at size h >> t so each wall is a single layer of tets whose
// four vertices all lie on its two faces (constrained).  Six regions.  Used
// by test_threshold.cpp: gmsh -3 -nt 1 -format mesh thin_wall.geo.  At the
// defaults (t 0.005, h 0.1; 23,843 tets with gmsh 4.x), improve's mode
// best before issue 27 ended at worst alpha 0.0611 with --threshold 0.2 and
// 0.0603 with the default 0.3; -setnumber t 0.02 -setnumber h 0.06 (98k
// tets) gave 0.3059 at 0.3 and 0.2898 at 0.5.
SetFactory("OpenCASCADE");
DefineConstant[ t = 0.005, h = 0.1 ];
Box(1) = {-1, -1, 0, 2, 2, 1};
Cylinder(2) = {0, 0, 0.1, 0, 0, 0.8, 0.6};
Cylinder(3) = {0, 0, 0.1, 0, 0, 0.8, 0.6 - t};
BooleanDifference(4) = { Volume{2}; Delete; }{ Volume{3}; Delete; };
Box(5) = {-0.9, -0.9, 0.2, t, 0.5, 0.6};
Rotate {{0, 0, 1}, {-0.9, -0.9, 0}, 0.5} { Volume{5}; }
Box(6) = {0.75, -0.5, 0.1, t, 1.0, 0.8};
Rotate {{0, 1, 0}, {0.75, 0, 0.5}, 0.3} { Volume{6}; }
BooleanFragments{ Volume{1}; Delete; }{ Volume{4, 5, 6}; Delete; }
Mesh.MeshSizeMax = h;
Mesh.MeshSizeMin = h;
