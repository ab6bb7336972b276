// Two unit cubes side by side, two physical volumes and a named skin:
// used by test_io_gmsh.cpp to read meshes that gmsh itself wrote.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Box(2) = {1, 0, 0, 1, 1, 1};
Coherence;
Physical Volume("left", 7) = {1};
Physical Volume("right", 8) = {2};
Physical Surface("skin", 3) = {1, 2, 3, 4, 5, 7, 8, 9, 10, 11};
Mesh.MeshSizeMax = 0.5;
