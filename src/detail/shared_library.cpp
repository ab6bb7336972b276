// The one source of libtetopt.so (CMakeLists.txt, TETOPT_BUILD_SHARED): the
// shared library is linked from every object of the static libtetopt.a
// (whole archive), compiled once with hidden visibility and the public API
// exported; a shared library target needs a source of its own.
