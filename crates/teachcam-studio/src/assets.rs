//! The web assets compiled into the binary.

/// uPlot 1.6.32 (MIT), the plotting library of the report and the studio's review.
pub const UPLOT_JS: &str = include_str!("../web/vendor/uplot/uPlot.iife.min.js");
/// uPlot's style sheet.
pub const UPLOT_CSS: &str = include_str!("../web/vendor/uplot/uPlot.min.css");
/// three.js 0.187.0 (MIT), the studio's 3-D view: the module entry.
pub const THREE_MODULE_JS: &str = include_str!("../web/vendor/three/three.module.js");
/// three.js's core, imported by the module entry as `./three.core.js`.
pub const THREE_CORE_JS: &str = include_str!("../web/vendor/three/three.core.js");
/// three.js's orbit controls (imports `three`, mapped to the module entry by the page).
pub const ORBIT_CONTROLS_JS: &str = include_str!("../web/vendor/three/OrbitControls.js");
