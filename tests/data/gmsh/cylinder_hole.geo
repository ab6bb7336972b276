// A cylinder with a spherical hole, surface only (gmsh -2 -format stl), for
// raw `tetgen -p` output: tests/scripts/test_insertion_hint.sh (issue 27).
SetFactory("OpenCASCADE");
DefineConstant[ h = 0.4 ];
Cylinder(1) = {0, 0, 0, 0, 0, 2, 1};
Sphere(2) = {0, 0, 1, 0.5};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
Mesh.MeshSizeMax = h;
