// Liver-shaped organ for the needle-steering scenes (see README.md in this folder).
// Modelled in millimetres and written in metres (Mesh.ScalingFactor).
// Frame: bounding-box centre at the origin; x = patient right (+) / left (-), y = anterior (+),
// z = superior (+, the diaphragm side). Right-handed (RAS-like).
// The element size is set from the command line: gmsh -3 liver.geo -setnumber lc 8.53 ...
SetFactory("OpenCASCADE");
DefineConstant[ lc = {8.53, Name "lc"} ];  // maximum element size (mm)

// right lobe: the large, thick part on the patient's right
Sphere(1) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {70, 55, 80}} { Volume{1}; }
Translate {33, 0, 0} { Volume{1}; }
// left lobe: smaller, flattened antero-posteriorly, higher, extending to the patient's left
Sphere(2) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {65, 33, 42}} { Volume{2}; }
Translate {-42, 6, 22} { Volume{2}; }
BooleanUnion(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };

// centre the bounding box at the origin
Geometry.OCCBoundsUseStl = 1;
bb() = BoundingBox Volume{3};
Translate {-(bb(0) + bb(3)) / 2, -(bb(1) + bb(4)) / 2, -(bb(2) + bb(5)) / 2} { Volume{3}; }
bb() = BoundingBox Volume{3};
Printf("liver bounding box (mm): %g %g %g .. %g %g %g", bb(0), bb(1), bb(2), bb(3), bb(4), bb(5));

// reproducible meshing: fixed seed, single thread, fixed algorithms
Mesh.CharacteristicLengthMax = lc;
Mesh.CharacteristicLengthMin = 0.5 * lc;
Mesh.CharacteristicLengthFromCurvature = 0;
Mesh.RandomSeed = 1;
Mesh.Algorithm = 6;    // Frontal-Delaunay surfaces
Mesh.Algorithm3D = 1;  // Delaunay volume
Mesh.Optimize = 1;
Mesh.OptimizeThreshold = 0.6;  // also improve tets of quality below 0.6 (removes slivers)
General.NumThreads = 1;
Mesh.ScalingFactor = 0.001;  // mm -> m
Mesh.Binary = 0;
