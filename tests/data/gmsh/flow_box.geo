// flow_box.geo -- a CFD case with named patches (bench/solver.sh,
// tests/scripts/test_simplefoam.sh): body_in_box.geo's domain (a flow box
// with an ellipsoidal body and a thin fin) with its surfaces in four
// physical groups, written as triangle refs 1-4 (Mesh.SaveElementTagType
// 2): inlet (x = -2), outlet (x = 4), sides (the four other box faces) and
// body (the ellipsoid and the fin).  tetopt writes them as OpenFOAM patches
// patch1 .. patch4.  The body's surface is fine (0.08 s) and the box's
// coarse (0.5 s), as in body_in_box.geo.
SetFactory("OpenCASCADE");
DefineConstant[ s = {1.0, Min 0.2, Max 4, Name "size factor"} ];
Box(1) = {-2, -1, -1, 6, 2, 2};
Sphere(2) = {0, 0, 0, 0.4};
Dilate {{0, 0, 0}, {1.5, 0.6, 0.6}} { Volume{2}; }
Box(3) = {0.3, -0.02, 0.1, 0.5, 0.04, 0.4};
BooleanUnion(4) = { Volume{2}; Delete; }{ Volume{3}; Delete; };
BooleanDifference(5) = { Volume{1}; Delete; }{ Volume{4}; Delete; };
Mesh.MeshSizeMin = 0.04 * s;
Mesh.MeshSizeMax = 0.5 * s;
Field[1] = MathEval;
Field[1].F = Sprintf("%g * (0.08 + 0.3 * Sqrt(x*x/2.25 + y*y + z*z))", s);
Background Field = 1;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.SaveElementTagType = 2;
e = 1e-3;
inlet() = Surface In BoundingBox{-2 - e, -1 - e, -1 - e, -2 + e, 1 + e, 1 + e};
outlet() = Surface In BoundingBox{4 - e, -1 - e, -1 - e, 4 + e, 1 + e, 1 + e};
// The body's surfaces lie within |y|, |z| < 0.9 (the box's sides do not).
body() = Surface In BoundingBox{-1.6, -0.9, -0.9, 1.6, 0.9, 0.9};
sides() = Surface{:};
sides() -= inlet();
sides() -= outlet();
sides() -= body();
Physical Surface("inlet", 1) = {inlet()};
Physical Surface("outlet", 2) = {outlet()};
Physical Surface("sides", 3) = {sides()};
Physical Surface("body", 4) = {body()};
Physical Volume("fluid", 1) = {5};
