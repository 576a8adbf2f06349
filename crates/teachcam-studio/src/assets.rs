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
/// The studio's page.
pub const STUDIO_HTML: &str = include_str!("../web/studio/index.html");
/// The studio's script (an ES module: three.js through the page's import map).
pub const STUDIO_JS: &str = include_str!("../web/studio/studio.js");
/// The studio's style sheet.
pub const STUDIO_CSS: &str = include_str!("../web/studio/studio.css");
/// The review's drawing script: `window.teachcamReview.draw(container, figures)` draws the
/// figure slots of `teachcam::report` with uPlot (the report page and the studio's Review tab).
pub const REVIEW_JS: &str = include_str!("../web/review.js");
