// The browser code of the HTML report's 3D view, compiled into the library
// (cmake/view3d.cmake generates the definition from node_modules/three and
// src/view3d.js at build time).
#pragma once
#include <string_view>

namespace tetopt::detail {

struct View3dAssets {
  bool built_in = false;              ///< false: built with TETOPT_VIEW3D=OFF (all texts empty)
  std::string_view three_version;     ///< "0.185.1"
  std::string_view three_core;        ///< build/three.core.min.js (ES module)
  std::string_view three_module;      ///< build/three.module.min.js, imports "./three.core.min.js"
  std::string_view orbit_controls;    ///< examples/jsm/controls/OrbitControls.js, imports "three"
  std::string_view app;               ///< src/view3d.js (ES module, loads the three above)
};

const View3dAssets& view3d_assets();

}  // namespace tetopt::detail
